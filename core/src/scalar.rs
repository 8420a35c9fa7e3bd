//! The scalar type the estimators are generic over: `f32` on the MCU, `f64` on the host.

use nalgebra::RealField;

/// A real scalar usable by every estimator in this crate.
///
/// Implemented for `f32` (the Cortex-M4F FPU is single precision) and `f64` (host references and
/// analysis). All transcendental functions come from nalgebra's `RealField`, which uses `libm` in
/// `no_std` builds, so the same code runs on both.
pub trait Real: RealField + Copy + Default {
    /// Machine epsilon (the gap between 1 and the next representable number).
    const EPS: Self;
    /// The smallest positive normal number.
    const MIN_POSITIVE: Self;
    /// Converts a literal (settings, constants) to this scalar.
    fn lit(x: f64) -> Self;
    /// Converts to `f64` (for reports and tests).
    fn to_f64(self) -> f64;
    /// `true` if neither NaN nor infinite.
    fn finite(self) -> bool;
    /// `self · 2^e`, exact unless it over- or underflows (`ldexp`).
    fn scale_pow2(self, e: i32) -> Self;
    /// The binary exponent `e` with `self = m·2^e`, `0.5 ≤ |m| < 1` (`frexp`); 0 for zero.
    fn exponent(self) -> i32;
    /// The larger of two numbers (NaN-free inputs assumed).
    #[inline]
    fn maxr(self, other: Self) -> Self {
        if self >= other {
            self
        } else {
            other
        }
    }
    /// The smaller of two numbers (NaN-free inputs assumed).
    #[inline]
    fn minr(self, other: Self) -> Self {
        if self <= other {
            self
        } else {
            other
        }
    }
}

impl Real for f32 {
    const EPS: Self = f32::EPSILON;
    const MIN_POSITIVE: Self = f32::MIN_POSITIVE;
    #[inline]
    fn scale_pow2(self, e: i32) -> Self {
        libm::ldexpf(self, e)
    }
    #[inline]
    fn exponent(self) -> i32 {
        libm::frexpf(self).1
    }
    #[inline]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
}

impl Real for f64 {
    const EPS: Self = f64::EPSILON;
    const MIN_POSITIVE: Self = f64::MIN_POSITIVE;
    #[inline]
    fn scale_pow2(self, e: i32) -> Self {
        libm::ldexp(self, e)
    }
    #[inline]
    fn exponent(self) -> i32 {
        libm::frexp(self).1
    }
    #[inline]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn finite(self) -> bool {
        self.is_finite()
    }
}
