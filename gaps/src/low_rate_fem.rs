//! The filter error method on the low-rate path: when an axis's output-error residuals show
//! process noise (turbulence), its baseline and every candidate are fitted with a steady-state
//! Kalman filter in the loop instead, so that the gusts' response is predicted from the
//! measurements rather than left in coloured residuals that bias the output error.
//!
//! ## The filter (Jategaonkar 2015, *Flight Vehicle System Identification*, 2nd ed., §5.2–5.5)
//! The axis's state equations `ẋ = f(x, θ) + w` with process noise `w`, measured outputs
//! `y = h(x, θ) + v`. The one-step prediction `x̂⁻_k` (the axis's RK4 step from `x̂_{k−1}`), the
//! innovation `ν_k = y_k − h(x̂⁻_k)` and the correction `x̂_k = x̂⁻_k + K ν_k` with a
//! **steady-state gain** `K` (eq. 5.20–5.26): the discrete Riccati equation of the model
//! linearised at the mean of the measured states, `Φ = exp(A Δt)` and `C` the averages of
//! `∂f/∂x`, `∂h/∂x` over the record at the output-error estimate, iterated to its fixed point:
//! `P⁻ = Φ P Φᵀ + Q_d`, `K = P⁻Cᵀ(C P⁻ Cᵀ + R)⁻¹`, `P = (I − KC)P⁻`. The gain is held fixed while
//! `θ` is estimated ("the gain held fixed", Jategaonkar's relaxation §5.5.2), so the innovations'
//! sensitivities are those of `oem.rs`'s simulation with the correction in the loop,
//! `S = S⁻ − K ∂ŷ⁻/∂θ`, and the Gauss–Newton step, the covariance relaxation (now of the
//! innovations, `B`), the block-sandwich σ from the information matrix `Σ Hᵀ B⁻¹ H`, the held-out
//! test and the naming rule are the output error's unchanged.
//!
//! ## Noise levels (reading chosen)
//! `R`, the measurement noise, is each output's white-noise level from its third differences
//! ([`white_noise_sd`], per manoeuvre, pooled), kept between 10⁻⁶ and 1 times the output-error
//! residuals' mean square (an output cannot be noisier than what the output error leaves).
//! The process noise is one scalar `κ`: the per-sample variance of state `i`'s noise is
//! `κ · R_OE,i`, the output-error residuals' mean square of the output that measures that state
//! (the first `NX` outputs of both axes are their states: α, `q`; β, `p`, `r`), with `κ` the
//! maximum of the innovation likelihood over [`KAPPAS`] at the output-error estimate. The seed's
//! recursive filter ([`aerosid_core::fem::FilterError`]) is not used: it is const-generic in the
//! number of parameters, which here changes with every candidate, and its RK4 sensitivities are
//! central differences in every parameter.
//!
//! ## The test for process noise
//! With the diagonal covariance estimated, twice the log-likelihood gain of the filter over the
//! output error at the same `θ` is `N Σ_i ln(R_OE,i / B_i)` (`N` samples, `B` the innovations'
//! mean square per output). Without process noise the filter can only whiten measurement noise
//! that is already white, and the gain is `χ²` with one degree of freedom (`κ`; its boundary at 0
//! makes the test conservative); the filter error method runs when the gain exceeds the `χ²₁`
//! 0.1 % point [`LR_CRITICAL`] — the filter must explain the residuals' colour far beyond chance.

use super::oem::{self, noise_of, Dynamics, Inputs, Setup, NY};
use super::signal::white_noise_sd;
use crate::LowRateMethod;
use nalgebra::DMatrix;

/// The process-noise levels tried: per-sample variance of each state's noise over the
/// output-error residuals' mean square of its output.
pub const KAPPAS: [f64; 8] = [0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0];

/// The upper 0.1 % point of `χ²₁`: the likelihood-ratio test of process noise.
pub const LR_CRITICAL: f64 = 10.83;

/// Iterations of the discrete Riccati equation at most.
const RICCATI_ITERATIONS: usize = 2000;

/// What the process-noise test decided for an axis: the gain of the filter error method (`None`:
/// output error) and the reason, in words.
pub(super) struct Decision {
    pub(super) gain: Option<DMatrix<f64>>,
    pub(super) note: String,
}

/// The process-noise test of an axis (module doc) at its output-error baseline; `Err` when the
/// baseline cannot be fitted.
pub(super) fn decide<D: Dynamics>(inp: &Inputs, setup: &Setup<D>, choice: LowRateMethod) -> Result<Decision, String> {
    if matches!(choice, LowRateMethod::OutputError) {
        return Ok(Decision {
            gain: None,
            note: "method of this axis: output error (the default; `--low-rate-method test` runs the filter error method where the residuals show process noise)".into(),
        });
    }
    let (spec, th, e) = oem::output_error_baseline(inp, setup)?;
    let r_oe = noise_of(&e);
    let n = e.len() as f64;
    let log_det = |e: &[[f64; NY]]| noise_of(e).iter().map(|b| b.ln()).sum::<f64>();
    let l_oe = log_det(&e);
    let Some((a, c)) = setup.mean_jacobians(&spec, &th) else {
        return Ok(Decision {
            gain: None,
            note: "method of this axis: output error (the model cannot be linearised for a filter)".into(),
        });
    };
    let nx = a.nrows();
    // nalgebra's matrix exponential needs finite entries (it scales by the norm); a step that is
    // not finite and positive has no discrete model.
    let step_s = setup.step_s();
    if !(step_s.is_finite() && step_s > 0.0 && a.iter().all(|v| v.is_finite())) {
        return Ok(Decision {
            gain: None,
            note: "method of this axis: output error (the linearised model is not finite: no filter can be formed)"
                .into(),
        });
    }
    let phi = (a * step_s).exp();
    let r_meas = measurement_noise(setup, &r_oe);
    let mut best: Option<(f64, f64, DMatrix<f64>, [f64; NY])> = None;
    for kappa in KAPPAS {
        let qd = DMatrix::<f64>::from_fn(nx, nx, |i, j| if i == j { kappa * r_oe[i] } else { 0.0 });
        let Some(k) = steady_gain(&phi, &c, &qd, &r_meas) else {
            continue;
        };
        let Some(innovations) = setup.innovations(&spec, &th, &k) else {
            continue;
        };
        let gain = n * (l_oe - log_det(&innovations));
        if best.as_ref().is_none_or(|b| gain > b.0) {
            best = Some((gain, kappa, k, noise_of(&innovations)));
        }
    }
    let Some((lr, kappa, k, b)) = best else {
        return Ok(Decision {
            gain: None,
            note: "method of this axis: output error (no steady-state filter could be formed)".into(),
        });
    };
    let ratios: Vec<String> = (0..NY)
        .map(|i| format!("{} {:.2}", D::OUTPUTS[i], b[i] / r_oe[i]))
        .collect();
    let measured = format!(
        "innovation likelihood gain over output error 2ΔlnL {lr:.1} at process noise κ {kappa} (χ²₁ 0.1 % point {LR_CRITICAL}); innovations' mean square over the output error's: {}",
        ratios.join(", ")
    );
    let run_filter = match choice {
        LowRateMethod::FilterError => true,
        _ => lr > LR_CRITICAL,
    };
    Ok(if run_filter {
        Decision {
            gain: Some(k),
            note: format!(
                "method of this axis: filter error (steady-state Kalman filter in the loop, gain held fixed): the output-error residuals show process noise: {measured}"
            ),
        }
    } else {
        Decision {
            gain: None,
            note: format!("method of this axis: output error: no process noise beyond chance: {measured}"),
        }
    })
}

/// Each output's measurement-noise variance: its white-noise level per manoeuvre, pooled, kept
/// between 10⁻⁶ and 1 times the output error's residual mean square `r_oe`.
fn measurement_noise<D: Dynamics>(setup: &Setup<D>, r_oe: &[f64; NY]) -> [f64; NY] {
    let y = setup.plant.y_m();
    core::array::from_fn(|i| {
        let (mut sum, mut len) = (0.0, 0.0);
        for &(a, b) in &setup.pieces {
            let x: Vec<f64> = y[a..b].iter().map(|r| r[i]).collect();
            sum += white_noise_sd(&x).powi(2) * x.len() as f64;
            len += x.len() as f64;
        }
        let r = if len > 0.0 { sum / len } else { 0.0 };
        r.clamp(1e-6 * r_oe[i], r_oe[i])
    })
}

/// The steady-state Kalman gain `K` (`NX × NY`) of `x_{k+1} = Φ x_k + w_k`, `y_k = C x_k + v_k`
/// with `cov w = Q_d`, `cov v = diag(r)`: the discrete Riccati equation iterated from `P = Q_d`
/// until `K` moves by less than 10⁻¹⁰ relative (Joseph form for `P`). `None` when it does not
/// converge or a matrix is singular.
pub(super) fn steady_gain(
    phi: &DMatrix<f64>,
    c: &DMatrix<f64>,
    qd: &DMatrix<f64>,
    r: &[f64; NY],
) -> Option<DMatrix<f64>> {
    let nx = phi.nrows();
    let rm = DMatrix::<f64>::from_diagonal(&nalgebra::DVector::from_column_slice(r));
    let eye = DMatrix::<f64>::identity(nx, nx);
    let mut p = qd.clone();
    let mut k_prev = DMatrix::<f64>::zeros(nx, NY);
    for _ in 0..RICCATI_ITERATIONS {
        let pm = phi * &p * phi.transpose() + qd;
        let s = c * &pm * c.transpose() + &rm;
        let k = &pm * c.transpose() * s.cholesky()?.inverse();
        let ikc = &eye - &k * c;
        p = &ikc * &pm * ikc.transpose() + &k * &rm * k.transpose();
        let moved = (&k - &k_prev).norm();
        let scale = k.norm().max(f64::MIN_POSITIVE);
        if !moved.is_finite() {
            return None;
        }
        k_prev = k;
        if moved <= 1e-10 * scale {
            return Some(k_prev);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scalar random walk measured directly (`Φ = 1`, `C = 1`): the steady-state gain is
    /// known in closed form, `P⁻ = (q + √(q² + 4qr))/2`, `K = P⁻/(P⁻ + r)`.
    #[test]
    fn the_steady_gain_of_a_random_walk_is_the_closed_form() {
        let (q, r) = (0.3, 2.0);
        let phi = DMatrix::<f64>::identity(1, 1);
        let mut c = DMatrix::<f64>::zeros(NY, 1);
        c[(0, 0)] = 1.0;
        let qd = DMatrix::<f64>::from_element(1, 1, q);
        // The other outputs do not see the state; their noise does not matter.
        let k = steady_gain(&phi, &c, &qd, &[r, 1.0, 1.0, 1.0]).expect("converges");
        let pm = (q + (q * q + 4.0 * q * r).sqrt()) / 2.0;
        assert!((k[(0, 0)] - pm / (pm + r)).abs() < 1e-9, "{k}");
        for i in 1..NY {
            assert!(k[(0, i)].abs() < 1e-12, "{k}");
        }
    }
}
