//! The scalar type the estimators are generic over: `f32` on the MCU, `f64` on the host.

use nalgebra::RealField;

/// A real scalar usable by every estimator in this crate.
///
/// Implemented for `f32` (the Cortex-M4F FPU is single precision) and `f64` (host references and
/// analysis). All transcendental functions come from nalgebra's `RealField`, which uses `libm` in
/// `no_std` builds, so the same code runs on both.
pub trait Real: RealField + Copy + Default {
    /// `0` as a constant (for `const` initialisers such as the firmware's statics).
    const ZERO: Self;
    /// `1` as a constant.
    const ONE: Self;
    /// Machine epsilon (the gap between 1 and the next representable number).
    const EPS: Self;
    /// The smallest positive normal number.
    const MIN_POSITIVE: Self;
    /// `EPS.root()`, bit for bit (a constant instead of a square root per call).
    const SQRT_EPS: Self;
    /// `MIN_POSITIVE.root()`, bit for bit.
    const SQRT_MIN_POSITIVE: Self;
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
    /// Square root, the one every estimator calls (not `RealField::sqrt`): see the impls.
    fn root(self) -> Self;
    /// `(sin x, cos x)`, the one the synthesis calls: see the impls.
    fn sin_cos_fast(self) -> (Self, Self);
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
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const EPS: Self = f32::EPSILON;
    const MIN_POSITIVE: Self = f32::MIN_POSITIVE;
    const SQRT_EPS: Self = sqrt_f32(f32::EPSILON);
    const SQRT_MIN_POSITIVE: Self = sqrt_f32(f32::MIN_POSITIVE);
    /// A multiplication by the normal number `2^e` when there is one (the same single rounding as
    /// `ldexpf`), `ldexpf` otherwise.
    #[inline]
    fn scale_pow2(self, e: i32) -> Self {
        if (-126..=127).contains(&e) {
            self * f32::from_bits(((e + 127) as u32) << 23)
        } else {
            libm::ldexpf(self, e)
        }
    }
    /// Read from the bits, as `frexpf` defines it: for a normal number from the exponent field,
    /// for a subnormal one from the position of the mantissa's leading one (`m·2⁻¹⁴⁹` with
    /// `m < 2²³`), 0 for zero, ±∞ and NaN. (libm's `frexpf` handles subnormals by recursing once,
    /// which the firmware's static stack bound would have to special-case.)
    #[inline]
    fn exponent(self) -> i32 {
        let bits = self.to_bits();
        let biased = ((bits >> 23) & 0xff) as i32;
        let mantissa = bits & 0x007f_ffff;
        match biased {
            0xff => 0,
            0 if mantissa == 0 => 0,
            0 => (32 - mantissa.leading_zeros()) as i32 - 149,
            _ => biased - 126,
        }
    }
    #[inline]
    fn lit(x: f64) -> Self {
        x as f32
    }
    /// [`sqrt_f32`]: three Newton steps in hardware `f32` (≤ 1 ulp) instead of libm's bit-by-bit
    /// correctly rounded `sqrtf` (≈ 250 instructions on the Cortex-M4F, which has `vsqrt.f32` but
    /// no stable way to reach it from safe `no_std` Rust). Host and MCU run the same code, so their
    /// `f32` results stay bit-identical.
    #[inline]
    fn root(self) -> Self {
        sqrt_f32(self)
    }
    /// [`sin_cos_f32`]: polynomials for `|x| ≤ π/4` (the vane angles), libm beyond. libm's `sinf`
    /// and `cosf` evaluate their kernels in `f64`, which is software on the M4F (≈ 1 300
    /// instructions per call).
    #[inline]
    fn sin_cos_fast(self) -> (Self, Self) {
        sin_cos_f32(self)
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
    const ZERO: Self = 0.0;
    const ONE: Self = 1.0;
    const EPS: Self = f64::EPSILON;
    const MIN_POSITIVE: Self = f64::MIN_POSITIVE;
    // 2⁻²⁶ and 2⁻⁵¹¹: exact square roots of 2⁻⁵² and 2⁻¹⁰²², which the correctly rounded `sqrt` returns.
    const SQRT_EPS: Self = 1.490_116_119_384_765_6e-8;
    const SQRT_MIN_POSITIVE: Self = 1.491_668_146_240_041_3e-154;
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
    /// libm's correctly rounded `sqrt`.
    #[inline]
    fn root(self) -> Self {
        libm::sqrt(self)
    }
    /// libm's `sincos`.
    #[inline]
    fn sin_cos_fast(self) -> (Self, Self) {
        libm::sincos(self)
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

/// `√x` in `f32` within 1 ulp: an exponent-halving first guess (≤ 3.5 % off), then three Newton
/// steps `y ← (y + x/y)/2` (error 6·10⁻⁴, 2·10⁻⁷, then rounding). Subnormal `x` is scaled by 2²⁴
/// first. `√±0 = ±0`, `√+∞ = +∞`, NaN for negative or NaN `x` (as IEEE `sqrt`).
pub const fn sqrt_f32(x: f32) -> f32 {
    // Fast path first (positive normal finite `x`: one range test); the arithmetic is the same as
    // on the general path, so the result is too.
    let bits = x.to_bits();
    // Positive normal finite: the bits lie in [MIN_POSITIVE, INFINITY) (one unsigned comparison).
    if bits.wrapping_sub(0x0080_0000) < 0x7f00_0000 {
        return sqrt_newton(x);
    }
    if !(x > 0.0) {
        // ±0 stays, negative and NaN give NaN.
        return if x == 0.0 { x } else { f32::NAN };
    }
    if x == f32::INFINITY {
        return x;
    }
    // Subnormal.
    sqrt_newton(x * 16_777_216.0) * (1.0 / 4096.0)
}

/// The first guess and three Newton steps of [`sqrt_f32`] for a positive normal finite `x`.
#[inline(always)]
const fn sqrt_newton(x: f32) -> f32 {
    let mut y = f32::from_bits((x.to_bits() >> 1) + 0x1fbd_1df5);
    y = 0.5 * (y + x / y);
    y = 0.5 * (y + x / y);
    y = 0.5 * (y + x / y);
    y
}

/// `(sin x, cos x)` in `f32`: for `|x| ≤ π/4` odd/even Taylor polynomials to `x¹¹`/`x¹²` in Horner
/// form (truncation below 10⁻¹¹, so the result is within a few ulp); libm's `sincosf` otherwise.
pub fn sin_cos_f32(x: f32) -> (f32, f32) {
    if !(x.abs() <= core::f32::consts::FRAC_PI_4) {
        return libm::sincosf(x);
    }
    let x2 = x * x;
    let s = x
        * (1.0
            + x2 * (-1.0 / 6.0
                + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0 + x2 * (-1.0 / 39_916_800.0))))));
    let c = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0
                + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0 + x2 * (-1.0 / 3_628_800.0 + x2 / 479_001_600.0)))));
    (s, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units in the last place between two positive finite `f32`.
    fn ulps(a: f32, b: f32) -> u32 {
        a.to_bits().abs_diff(b.to_bits())
    }

    #[test]
    fn sqrt_f32_is_within_one_ulp_over_the_whole_range() {
        // Every 997th bit pattern of the positive finite floats (subnormals included): ≈ 2.1·10⁶ values.
        let mut worst = 0;
        let mut bits = 1u32;
        while bits < f32::INFINITY.to_bits() {
            let x = f32::from_bits(bits);
            let exact = (x as f64).sqrt() as f32; // correctly rounded: f64 sqrt then one rounding
            worst = worst.max(ulps(sqrt_f32(x), exact));
            bits += 997;
        }
        assert!(worst <= 1, "worst {worst} ulp");
        assert_eq!(sqrt_f32(0.0).to_bits(), 0.0f32.to_bits());
        assert_eq!(sqrt_f32(-0.0).to_bits(), (-0.0f32).to_bits());
        assert!(sqrt_f32(-1.0).is_nan() && sqrt_f32(f32::NAN).is_nan());
        assert_eq!(sqrt_f32(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn f32_exponent_and_scale_pow2_equal_libm() {
        let mut bits = 1u32;
        while bits < f32::INFINITY.to_bits() {
            for x in [f32::from_bits(bits), -f32::from_bits(bits)] {
                assert_eq!(x.exponent(), libm::frexpf(x).1, "{x:e}");
                for e in [-300, -150, -127, -126, -40, -1, 0, 1, 40, 127, 128, 300] {
                    assert_eq!(x.scale_pow2(e).to_bits(), libm::ldexpf(x, e).to_bits(), "{x:e} {e}");
                }
            }
            bits += 99_991;
        }
        assert_eq!(0.0f32.exponent(), 0);
        // Every subnormal binade, its ends, and the non-finite values.
        for k in 0..23 {
            for m in [1u32 << k, (2u32 << k) - 1] {
                for x in [f32::from_bits(m), -f32::from_bits(m)] {
                    assert_eq!(x.exponent(), libm::frexpf(x).1, "{x:e}");
                }
            }
        }
        for x in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN, -0.0] {
            assert_eq!(x.exponent(), libm::frexpf(x).1, "{x:e}");
        }
    }

    #[test]
    fn hoisted_square_root_constants_equal_the_computed_ones() {
        assert_eq!(<f32 as Real>::SQRT_EPS.to_bits(), f32::EPSILON.root().to_bits());
        assert_eq!(
            <f32 as Real>::SQRT_MIN_POSITIVE.to_bits(),
            f32::MIN_POSITIVE.root().to_bits()
        );
        assert_eq!(<f64 as Real>::SQRT_EPS.to_bits(), f64::EPSILON.root().to_bits());
        assert_eq!(
            <f64 as Real>::SQRT_MIN_POSITIVE.to_bits(),
            f64::MIN_POSITIVE.root().to_bits()
        );
    }

    #[test]
    fn sin_cos_f32_is_within_two_ulp_on_the_polynomial_range_and_libm_beyond() {
        let mut worst = 0.0f64;
        for i in -100_000..=100_000 {
            let x = i as f32 * (core::f32::consts::FRAC_PI_4 / 100_000.0);
            let (s, c) = sin_cos_f32(x);
            let (se, ce) = ((x as f64).sin(), (x as f64).cos());
            // Error in ulps of the exact value (absolute near sin = 0).
            let es = (s as f64 - se).abs() / (f32::EPSILON as f64 * se.abs().max(f32::MIN_POSITIVE as f64));
            let ec = (c as f64 - ce).abs() / (f32::EPSILON as f64 * ce.abs());
            worst = worst.max(es).max(ec);
        }
        assert!(worst <= 2.0, "worst {worst} ε relative");
        assert_eq!(sin_cos_f32(1.0), libm::sincosf(1.0));
    }
}
