//! The low-rate path's intersample model: a measured input between its samples.
//!
//! The output error integrates the model across each sample interval, so it needs every measured
//! input (the surfaces, the measured states, the thrust, `q̄`) between samples. At 10 Hz a
//! surface moves within one interval, and how its path is reconstructed there decides the timing
//! the fit sees. Linear interpolation between samples passes a sinusoid of period `P` with the gain
//! `sinc²(πT/P)` (`T` the interval; 0.87 at 2 Hz and 10 Hz): the model is driven by a surface
//! whose fast part is too small, and the fit makes up for it with a larger control derivative and
//! a surface-rate term — a false delay (docs/model-gaps.md, "Where the false delay comes from").
//!
//! The reconstruction here matches how the channel was formed ([`Sampling`]):
//!
//! * **Point samples** (the signal at its time stamp): the interpolating cubic spline through
//!   the samples. Its kernel is symmetric on the uniform grid, so it shifts no phase, and its
//!   gain stays within 1 % of one up to a fifth of the sample rate.
//! * **Centred block means** (the signal's mean over the interval around its stamp): the exact
//!   model is a mean-preserving (histopolating) reconstruction of the input — the quadratic spline
//!   `f` with knots at the interval edges whose mean over every interval is that interval's
//!   sample — and outputs that are the means of the simulated outputs over the same intervals.
//!   For a response linear in the input (the control and rate terms are), the mean over an
//!   interval of the response to `f` is the response at its centre to the moving mean of `f`, and
//!   that moving mean, `(F(t + T/2) − F(t − T/2))/T` with `F` the cubic antiderivative of `f`, is
//!   a C² cubic with knots at the sample instants that passes through every sample: the same
//!   interpolating cubic spline. So point outputs driven by the cubic spline through the means
//!   *are* the histopolating model with averaged outputs, without averaging the outputs inside
//!   the filter's one-step prediction.
//!
//! A surface's rate (the surface-rate terms, a delay's first-order form `δ(t − τ) ≈ δ − τ δ̇`) is
//! the derivative of the same reconstruction, so a fitted delay is a shift of the path the model
//! is driven by.
//!
//! What no reconstruction resolves is the timing within one interval: where the source does not
//! say how a channel was formed ([`Sampling::Unstated`]), one channel's sample may be its mean
//! over the interval before the stamp and another's its value at the stamp, half an interval
//! apart; and a surface that moves within one interval is placed there by one sample. So a
//! surface delay within half an interval is not decided at this rate ([`timing_resolution_s`]).
//!
//! The spline is a uniform-grid cubic with parabolic run-out ends (the end curvature equals its
//! neighbour's), solved per manoeuvre by the Thomas algorithm: twenty lines, evaluated in the
//! integration's inner loop at (sample, fraction), where a general spline crate's search for the
//! interval and its boundary handling would add cost and a dependency for nothing. A manoeuvre
//! shorter than four samples, or with a non-finite sample in a channel, keeps that channel linear.

use crate::io::measured::Sampling;

/// Per sample, `c_k = M_k h²/6` (`M_k` the spline's second derivative at sample `k`) of `x`,
/// one cubic spline per piece `(a, b)`: the equations `c_{k−1} + 4c_k + c_{k+1} = x_{k−1} −
/// 2x_k + x_{k+1}` inside a piece, `c_a = c_{a+1}` and `c_{b−1} = c_{b−2}` at its ends.
pub(super) fn curvature(x: &[f64], pieces: &[(usize, usize)]) -> Vec<f64> {
    let mut c = vec![0.0; x.len()];
    for &(a, b) in pieces {
        let b = b.min(x.len());
        if b < a + 4 || x[a..b].iter().any(|v| !v.is_finite()) {
            continue;
        }
        // Unknowns c_{a+1} … c_{b−2}; the ends fold into the first and last diagonal entry.
        let n = b - a - 2;
        let mut diag = vec![4.0; n];
        diag[0] += 1.0;
        diag[n - 1] += 1.0;
        let mut rhs: Vec<f64> = (a + 1..b - 1).map(|k| x[k - 1] - 2.0 * x[k] + x[k + 1]).collect();
        // Thomas algorithm with unit off-diagonals.
        for i in 1..n {
            let w = 1.0 / diag[i - 1];
            diag[i] -= w;
            rhs[i] -= w * rhs[i - 1];
        }
        let mut sol = vec![0.0; n];
        sol[n - 1] = rhs[n - 1] / diag[n - 1];
        for i in (0..n - 1).rev() {
            sol[i] = (rhs[i] - sol[i + 1]) / diag[i];
        }
        c[a + 1..b - 1].copy_from_slice(&sol);
        c[a] = sol[0];
        c[b - 1] = sol[n - 1];
    }
    c
}

/// The spline of `x` (curvatures `c` from [`curvature`]) at sample `k` plus the fraction `fr` of
/// the interval to `k + 1`.
pub(super) fn at(x: &[f64], c: &[f64], k: usize, fr: f64) -> f64 {
    if fr == 0.0 || k + 1 >= x.len() {
        return x[k];
    }
    let g = 1.0 - fr;
    x[k] + fr * (x[k + 1] - x[k]) + c[k] * (g * g * g - g) + c[k + 1] * (fr * fr * fr - fr)
}

/// The spline's time derivative at sample `k` plus `fr`, the interval `h_s` long.
pub(super) fn slope(x: &[f64], c: &[f64], k: usize, fr: f64, h_s: f64) -> f64 {
    let (k, fr) = if k + 1 >= x.len() && k > 0 {
        (k - 1, 1.0)
    } else {
        (k, fr)
    };
    if k + 1 >= x.len() {
        return 0.0;
    }
    let g = 1.0 - fr;
    (x[k + 1] - x[k] + c[k] * (1.0 - 3.0 * g * g) + c[k + 1] * (3.0 * fr * fr - 1.0)) / h_s
}

/// The timing a channel logged at interval `h_s` leaves unresolved, s: a surface delay whose
/// size is within it is not decided at this rate. Half an interval, for either of two reasons
/// ([`why_unresolved`]):
///
/// * the formation unstated ([`Sampling::Unstated`]): each channel's sample may be the signal at
///   its stamp or its mean over the interval before it, and a mean over `[t − h, t]` is, to first
///   order in the signal's rate, the signal at `t − h/2`. A shift common to every channel moves no
///   input against an output, but a surface averaged and a rate sampled (or the reverse) are
///   shifted against each other by `h/2`;
/// * the formation stated: the reconstruction above is then the formation's own and phase-free
///   for motion at random phase to the samples, but a surface that moves within one interval is
///   placed there by one number per interval (its sample), which does not say where in the
///   interval it moved: the centroid of that motion may lie anywhere in it, up to `h/2` from
///   where the reconstruction puts it. When the motion is locked to the logger's clock (the
///   autopilot's loop drives the surfaces and stamps the log; a test card's inputs switch on its
///   ticks), these errors do not average out over the record.
pub(crate) fn timing_resolution_s(h_s: f64) -> f64 {
    h_s / 2.0
}

/// Why a surface delay within [`timing_resolution_s`] is not decided, for the report.
pub(crate) fn why_unresolved(sampling: Sampling) -> &'static str {
    match sampling {
        Sampling::Unstated => {
            "the data do not say whether each channel's sample is the signal at its time stamp or its mean over the interval before it, so the surface and the response it drives may be shifted against each other by up to half an interval by how they were logged"
        }
        Sampling::Points | Sampling::CentredMeans => {
            "a surface that moves within one sample interval is placed there by one sample, which does not say where in the interval it moved, so its timing is known to half an interval only"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The spline passes through its samples, reproduces a cubic inside a piece exactly away
    /// from the run-out ends (whose curvature is forced equal to the neighbour's), and its
    /// derivative is that of the cubic there.
    #[test]
    fn the_spline_interpolates_and_reproduces_a_parabola() {
        let h = 0.1;
        let f = |t: f64| 0.3 + 2.0 * t - 1.5 * t * t;
        let x: Vec<f64> = (0..30).map(|k| f(k as f64 * h)).collect();
        let c = curvature(&x, &[(0, 30)]);
        for k in 0..29 {
            assert!((at(&x, &c, k, 0.0) - x[k]).abs() < 1e-15);
            for fr in [0.25, 0.5, 0.75] {
                let t = (k as f64 + fr) * h;
                // A parabola has constant curvature: the run-out ends are exact for it.
                assert!((at(&x, &c, k, fr) - f(t)).abs() < 1e-12, "{k} {fr}");
                assert!((slope(&x, &c, k, fr, h) - (2.0 - 3.0 * t)).abs() < 1e-10, "{k} {fr}");
            }
        }
    }

    /// A sinusoid at a fifth of the sample rate: linear interpolation loses 13 % at the interval's
    /// centre (`cos(πT/P)`), the spline about 1 %; and neither shifts it: its phase error at the
    /// centres averages to zero.
    #[test]
    fn the_spline_keeps_the_gain_and_phase_of_a_sampled_sinusoid() {
        use core::f64::consts::TAU;
        let h = 0.1;
        let w = TAU * 2.0;
        let n = 200;
        let x: Vec<f64> = (0..n).map(|k| (w * k as f64 * h).sin()).collect();
        let c = curvature(&x, &[(0, n)]);
        let (mut lin, mut spl, mut sin_ref, mut cos_proj) = (0.0, 0.0, 0.0, 0.0);
        for k in 20..n - 20 {
            let t = (k as f64 + 0.5) * h;
            let s = at(&x, &c, k, 0.5);
            lin += (0.5 * (x[k] + x[k + 1])) * (w * t).sin();
            spl += s * (w * t).sin();
            sin_ref += (w * t).sin().powi(2);
            cos_proj += s * (w * t).cos();
        }
        let (g_lin, g_spl) = (lin / sin_ref, spl / sin_ref);
        assert!((g_lin - 0.809).abs() < 0.005, "{g_lin}");
        assert!((g_spl - 1.0).abs() < 0.02, "{g_spl}");
        assert!((cos_proj / sin_ref).abs() < 1e-3, "{}", cos_proj / sin_ref);
    }

    /// A non-finite sample leaves its piece linear; a piece of three samples too.
    #[test]
    fn a_gap_or_a_short_piece_stays_linear() {
        let x = [0.0, 1.0, f64::NAN, 0.5, 0.2, 0.0, 1.0, 0.0];
        let c = curvature(&x, &[(0, 5), (5, 8)]);
        assert!(c.iter().all(|v| *v == 0.0));
    }

    #[test]
    fn half_an_interval_is_left_unresolved_with_the_formation_s_reason() {
        assert_eq!(timing_resolution_s(0.1), 0.05);
        assert!(why_unresolved(Sampling::Unstated).contains("do not say"));
        assert!(why_unresolved(Sampling::CentredMeans).contains("within one sample interval"));
    }
}
