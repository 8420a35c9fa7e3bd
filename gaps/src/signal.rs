//! Signal helpers of the model-gap analysis: Savitzky–Golay smoothing, a 5-point central
//! derivative, time shifts by linear interpolation, and the normal quantile for thresholds.
//!
//! *Why smooth everything the same way*: an aerodynamic model is static (`C(t) = f(x(t))`), so a
//! linear time-invariant filter applied to the coefficient **and** to every regressor keeps a linear
//! relation exact (Klein & Morelli, *Aircraft System Identification*, 2006, §11.2 on smoothing before
//! equation-error modelling). The smoother here is the quadratic Savitzky–Golay filter (a local
//! least-squares parabola over `2M+1` samples, value at the centre); it reduces white noise by
//! `√c₀` (`c₀ = 3(3M²+3M−1)/((2M−1)(2M+1)(2M+3))`, 0.107 for `M = 10`), which keeps the
//! errors-in-variables bias of least squares small. Angular accelerations are differentiated
//! **before** smoothing by the 5-point central difference `(f₋₂ − 8f₋₁ + 8f₁ − f₂)/(12h)` (truncation
//! error `h⁴f⁽⁵⁾/30`, negligible at 100 Hz for rigid-body motion), so that the smoothed derivative
//! is the smoothed true derivative and the pointwise relation of eq. 2 survives the filter.

/// Quadratic Savitzky–Golay smoothing with half-width `m` (window `2m+1`). Near the ends the window
/// is truncated and the local parabola is evaluated off-centre. `m = 0` or fewer than 4 samples
/// returns the input.
pub fn sg_smooth(x: &[f64], m: usize) -> Vec<f64> {
    let n = x.len();
    if m == 0 || n < 4 {
        return x.to_vec();
    }
    let mut out = vec![0.0; n];
    // Interior weights: c_k = (3(3m²+3m−1) − 15k²) / ((2m−1)(2m+1)(2m+3)).
    let mf = m as f64;
    let den = (2.0 * mf - 1.0) * (2.0 * mf + 1.0) * (2.0 * mf + 3.0);
    let w: Vec<f64> = (0..=2 * m)
        .map(|j| {
            let k = j as f64 - mf;
            (3.0 * (3.0 * mf * mf + 3.0 * mf - 1.0) - 15.0 * k * k) / den
        })
        .collect();
    // The interior: tap pair by tap pair over every sample (the weights are symmetric, so
    // `w_k (x_{i−k} + x_{i+k})` halves the products; the inner loop vectorises).
    if n > 2 * m {
        let len = n - 2 * m;
        let inner = &mut out[m..n - m];
        for (o, xv) in inner.iter_mut().zip(&x[m..m + len]) {
            *o = w[m] * xv;
        }
        for k in 1..=m {
            let (lo, hi) = (&x[m - k..m - k + len], &x[m + k..m + k + len]);
            for ((o, a), b) in inner.iter_mut().zip(lo).zip(hi) {
                *o += w[m - k] * (a + b);
            }
        }
    }
    for i in (0..n).filter(|&i| i < m || i + m >= n) {
        let lo = i.saturating_sub(m);
        let hi = (i + m).min(n - 1);
        out[i] = local_quadratic(x, lo, hi, i);
    }
    out
}

/// Value at `at` of the least-squares parabola through `x[lo..=hi]` (indices as abscissa).
fn local_quadratic(x: &[f64], lo: usize, hi: usize, at: usize) -> f64 {
    // Normal equations in the centred abscissa k = j − at.
    let mut s = [0.0f64; 5];
    let mut b = [0.0f64; 3];
    for (j, &xj) in x.iter().enumerate().take(hi + 1).skip(lo) {
        let k = j as f64 - at as f64;
        let mut p = 1.0;
        for item in s.iter_mut() {
            *item += p;
            p *= k;
        }
        b[0] += xj;
        b[1] += xj * k;
        b[2] += xj * k * k;
    }
    let a = nalgebra::Matrix3::new(s[0], s[1], s[2], s[1], s[2], s[3], s[2], s[3], s[4]);
    let rhs = nalgebra::Vector3::new(b[0], b[1], b[2]);
    match a.lu().solve(&rhs) {
        Some(c) => c[0],
        None => x[at],
    }
}

/// First derivative by the 5-point central difference on a uniform time base `h_s` (3-point and
/// one-sided differences at the ends).
pub fn derivative(x: &[f64], h_s: f64) -> Vec<f64> {
    let n = x.len();
    let mut d = vec![0.0; n];
    if n < 2 {
        return d;
    }
    for i in 0..n {
        d[i] = if i >= 2 && i + 2 < n {
            (x[i - 2] - 8.0 * x[i - 1] + 8.0 * x[i + 1] - x[i + 2]) / (12.0 * h_s)
        } else if i >= 1 && i + 1 < n {
            (x[i + 1] - x[i - 1]) / (2.0 * h_s)
        } else if i == 0 {
            (x[1] - x[0]) / h_s
        } else {
            (x[i] - x[i - 1]) / h_s
        };
    }
    d
}

/// `Σᵢ aᵢ bᵢ` over the shorter of the two, with eight partial sums (independent accumulators let
/// the compiler use vector instructions; a serial sum cannot be reordered).
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0f64; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for j in 0..8 {
            acc[j] += x[j] * y[j];
        }
    }
    let tail: f64 = ra.iter().zip(rb).map(|(x, y)| x * y).sum();
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7])) + tail
}

/// `(sin x, cos x)` by musl's `sincos` (the `libm` crate, < 1 ulp): one argument reduction for
/// both, and none for `|x| < π/4`. The standard library's `f64::sin_cos` calls glibc's `sin`
/// and `cos` in turn, each saving and restoring the rounding mode — in the per-sample loops of
/// the analysis (attitude kinematics, force synthesis) that bookkeeping cost more than the
/// polynomials.
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

/// `x(t + shift_s)` on the same uniform base (linear interpolation, held at the ends): with a
/// positive shift, a channel measured `shift_s` late is moved back onto the time base.
pub fn shift(x: &[f64], h_s: f64, shift_s: f64) -> Vec<f64> {
    let n = x.len();
    let s = shift_s / h_s;
    if n == 0 || s == 0.0 {
        return x.to_vec();
    }
    if !s.is_finite() || s.abs() >= n as f64 {
        let end = if s > 0.0 { x[n - 1] } else { x[0] };
        return vec![if s.is_nan() { f64::NAN } else { end }; n];
    }
    // Whole samples and the fraction, the same for every sample: `x(i + m + f)`.
    let m = s.floor();
    let f = s - m;
    let m = m as isize;
    (0..n as isize)
        .map(|i| {
            let j = i + m;
            if j < 0 {
                x[0]
            } else if j as usize >= n - 1 {
                x[n - 1]
            } else {
                let j = j as usize;
                x[j] + f * (x[j + 1] - x[j])
            }
        })
        .collect()
}

/// The upper `p` quantile `z` of the standard normal (`P(Z > z) = p`), by bisection on
/// `erfc(z/√2)/2` (accurate to 1e-12 for `p` in (1e-300, 0.5]).
pub fn normal_upper_quantile(p: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 40.0f64);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if 0.5 * libm::erfc(mid / core::f64::consts::SQRT_2) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The white-noise standard deviation of a series (third differences, robust scale), shared
/// with the reading layer's α-free mode.
pub use crate::io::signal::white_noise_sd;

/// The variance gain `Σ wₖ²` of the linear operation `op` (applied to a unit impulse in the middle
/// of a zero series of `len` samples): white noise of variance `σ²` comes out with `σ² Σ wₖ²`.
pub fn variance_gain(op: impl Fn(&[f64]) -> Vec<f64>, len: usize) -> f64 {
    let mut x = vec![0.0; len.max(3)];
    let mid = x.len() / 2;
    x[mid] = 1.0;
    op(&x).iter().map(|v| v * v).sum()
}

/// Mean of a slice (0 for an empty one).
pub fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        0.0
    } else {
        x.iter().sum::<f64>() / x.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smoothing_keeps_parabolas_and_derivative_is_exact_on_quartics() {
        let x: Vec<f64> = (0..50).map(|i| 0.3 + 0.1 * i as f64 - 0.002 * (i * i) as f64).collect();
        let s = sg_smooth(&x, 5);
        for (a, b) in x.iter().zip(&s) {
            assert!((a - b).abs() < 1e-9);
        }
        let h = 0.01;
        let y: Vec<f64> = (0..50).map(|i| (i as f64 * h).powi(4)).collect();
        let d = derivative(&y, h);
        for i in 2..48 {
            let t = i as f64 * h;
            assert!((d[i] - 4.0 * t * t * t).abs() < 1e-9);
        }
    }

    #[test]
    fn quantile_matches_tables() {
        // z_{0.025} = 1.959964, z_{0.0005} = 3.290527 (standard tables).
        assert!((normal_upper_quantile(0.025) - 1.959964).abs() < 1e-5);
        assert!((normal_upper_quantile(0.0005) - 3.290527).abs() < 1e-5);
    }

    #[test]
    fn white_noise_level_is_recovered_under_a_smooth_signal_and_steps() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        // GIVEN a 0.5 Hz sine of amplitude 1 with a step of 0.2 every 2 s (as a 3-2-1-1 input
        // every few seconds), sampled at 100 Hz, plus white noise σ = 0.01 (seeded)
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        let nd = Normal::new(0.0, 0.01).unwrap();
        let x: Vec<f64> = (0..5000)
            .map(|i| {
                let t = i as f64 * 0.01;
                let step = if (i / 200) % 2 == 0 { 0.2 } else { 0.0 };
                (core::f64::consts::TAU * 0.5 * t).sin() + step + nd.sample(&mut rng)
            })
            .collect();
        // THEN the estimate is within 5 % (the standard error of a median-based scale on ~5000
        // samples is ~1.7 %; the 1.5 % of third differences a step touches move the median by
        // ~2 %, the sine's third difference by < 0.1 %)
        let s = white_noise_sd(&x);
        assert!((s / 0.01 - 1.0).abs() < 0.05, "{s}");
        // AND a piecewise-constant series has none
        let c: Vec<f64> = (0..100).map(|i| (i / 10) as f64).collect();
        assert_eq!(white_noise_sd(&c), 0.0);
        // AND the Savitzky–Golay gain for M = 10 is c₀ = 0.107 (module doc)
        let g = variance_gain(|v| sg_smooth(v, 10), 101);
        assert!((g - 3.0 * 329.0 / (19.0 * 21.0 * 23.0)).abs() < 1e-12, "{g}");
    }

    #[test]
    fn shift_moves_a_late_channel_back() {
        let x: Vec<f64> = (0..20).map(|i| i as f64).collect();
        let s = shift(&x, 0.01, 0.025);
        assert!((s[3] - 5.5).abs() < 1e-12);
        // AND it is the series interpolated at `t + shift`, held at the ends, for shifts of
        // whole and fractional samples either way and past either end (the reference is the
        // definition, point by point); no shift returns the series itself
        let y: Vec<f64> = (0..50).map(|i| (i as f64 * 0.37).sin()).collect();
        let at = |p: f64| {
            let p = p.clamp(0.0, 49.0);
            let j = (p.floor() as usize).min(48);
            y[j] + (p - j as f64) * (y[j + 1] - y[j])
        };
        for samples in [0.0, 1.0, -3.0, 0.25, -0.25, 2.6, -7.4, 48.5, -49.5, 60.0, -60.0] {
            let s = shift(&y, 0.01, samples * 0.01);
            for (i, v) in s.iter().enumerate() {
                // 1e-12: the fraction is taken once rather than per sample (rounding of `i + s`)
                assert!(
                    (v - at(i as f64 + samples)).abs() < 1e-12,
                    "shift {samples}, sample {i}"
                );
            }
        }
        assert_eq!(shift(&y, 0.01, 0.0), y);
        assert!(shift(&y, 0.01, f64::NAN).iter().all(|v| v.is_nan()));
    }

    #[test]
    fn dot_equals_the_serial_sum() {
        // GIVEN lengths around the eight lanes and unequal lengths
        let a: Vec<f64> = (0..103).map(|i| (i as f64 * 0.31).cos()).collect();
        let b: Vec<f64> = (0..110).map(|i| 1.0 + (i as f64 * 0.17).sin()).collect();
        for n in [0, 1, 7, 8, 9, 16, 103] {
            // THEN the sum over the shorter agrees with the serial one to rounding (1e-13 of
            // the sum of |products| ≤ 2·103)
            let serial: f64 = a[..n].iter().zip(&b).map(|(x, y)| x * y).sum();
            assert!((dot(&a[..n], &b) - serial).abs() < 1e-13 * 206.0, "{n}");
        }
    }

    #[test]
    fn smoothing_by_taps_equals_the_per_sample_sums() {
        // GIVEN a rough series and the half-widths of the analysis, including one wider than
        // half the series (no interior)
        let x: Vec<f64> = (0..300)
            .map(|i| (i as f64 * 0.7).sin() + 0.01 * (i * i % 17) as f64)
            .collect();
        for m in [1, 5, 12, 25, 160] {
            // WHEN smoothed
            let s = sg_smooth(&x, m);
            // THEN every sample is its window's least-squares parabola at the sample (1e-12:
            // rounding of the two ways of summing)
            for (i, v) in s.iter().enumerate() {
                let (lo, hi) = (i.saturating_sub(m), (i + m).min(x.len() - 1));
                let r = local_quadratic(&x, lo, hi, i);
                assert!((v - r).abs() < 1e-12, "m {m}, sample {i}: {v} vs {r}");
            }
        }
    }
}
