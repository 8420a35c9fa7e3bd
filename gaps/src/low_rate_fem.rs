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
//! maximum of the innovation likelihood over [`KAPPAS`] at the output-error estimate.
//!
//! ## Tuned without the held-out data
//! `κ`, `R` and the linearisation are tuned on data, so the filter that predicts a held-out fold
//! must not have seen it: otherwise the held-out test would judge the candidates with a filter
//! fitted, among others, to the very gusts it is asked to predict. The filter of the estimation
//! (the gain `K` above) is tuned on the whole record, as the estimate itself is; for the held-out
//! test each fold `f` gets its own gain `K_f`, the same tuning on the other folds' samples only —
//! `R_OE`, `R`, the averaged Jacobians and `κ`'s likelihood over those samples, at the
//! output-error baseline refitted without the fold by one Gauss–Newton step (the held-out test's
//! leave-fold-out) — and the fold is predicted by the filter with `K_f` at the fit's `θ` refitted
//! by one Gauss–Newton step on the other folds' innovations of that filter (`oem.rs`'s held-out
//! test). Only the other folds' innovations are scored, but the tuning filter runs through the
//! whole record: its state is corrected by the fold's measurements, which reach the first samples
//! after the fold through the filter's memory (a steady-state gain forgets within a fraction of a
//! 2 s block; not measured). The process-noise test below (whether the filter runs at all) reads the whole record:
//! it chooses the method for the baseline and every candidate alike. The seed's
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

use super::oem::{self, noise_of, Dynamics, Inputs, Setup, Spec, NY};
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

/// What the process-noise test decided for an axis: the gain of the filter error method and the
/// gains that predict each held-out fold (`None`: output error), and the reason, in words.
pub(super) struct Decision {
    pub(super) gain: Option<(DMatrix<f64>, Vec<DMatrix<f64>>)>,
    pub(super) note: String,
}

impl Decision {
    fn output_error(note: impl Into<String>) -> Self {
        Decision {
            gain: None,
            note: note.into(),
        }
    }
}

/// The process-noise test of an axis (module doc) at its output-error baseline; `Err` when the
/// baseline cannot be fitted.
pub(super) fn decide<D: Dynamics>(inp: &Inputs, setup: &Setup<D>, choice: LowRateMethod) -> Result<Decision, String> {
    if matches!(choice, LowRateMethod::OutputError) {
        return Ok(Decision::output_error(
            "method of this axis: output error (the default; `--low-rate-method test` runs the filter error method where the residuals show process noise)",
        ));
    }
    let base = oem::output_error_baseline(inp, setup)?;
    let whole = match tune(setup, base.spec(), base.th(), base.e(), &setup.pieces) {
        Ok(t) => t,
        Err(why) => {
            return Ok(Decision::output_error(format!(
                "method of this axis: output error ({why})"
            )))
        }
    };
    let ratios: Vec<String> = (0..NY)
        .map(|i| format!("{} {:.2}", D::OUTPUTS[i], whole.b[i] / whole.r_oe[i]))
        .collect();
    let measured = format!(
        "innovation likelihood gain over output error 2ΔlnL {:.1} at process noise κ {} (χ²₁ 0.1 % point {LR_CRITICAL}); innovations' mean square over the output error's: {}",
        whole.lr,
        whole.kappa,
        ratios.join(", ")
    );
    let run_filter = match choice {
        LowRateMethod::FilterError => true,
        _ => whole.lr > LR_CRITICAL,
    };
    if !run_filter {
        return Ok(Decision::output_error(format!(
            "method of this axis: output error: no process noise beyond chance: {measured}"
        )));
    }
    // The held-out test's filters: per fold, the output-error baseline without the fold and the
    // filter tuned on the other folds' samples only.
    let mut fold_gains = Vec::with_capacity(setup.folds());
    let mut kappas = Vec::with_capacity(setup.folds());
    for fold in 0..setup.folds() {
        let tuned = setup
            .without_fold(&base, fold)
            .ok_or("the output-error baseline cannot be refitted without it")
            .and_then(|(th, e)| tune(setup, base.spec(), &th, &e, &setup.fold_ranges(fold, false)));
        match tuned {
            Ok(t) => {
                kappas.push(format!("{}", t.kappa));
                fold_gains.push(t.k);
            }
            Err(why) => {
                return Ok(Decision::output_error(format!(
                    "method of this axis: output error: the residuals show process noise ({measured}), but no filter could be tuned without held-out fold {}: {why}",
                    fold + 1
                )))
            }
        }
    }
    Ok(Decision {
        gain: Some((whole.k, fold_gains)),
        note: format!(
            "method of this axis: filter error (steady-state Kalman filter in the loop, gain held fixed): the output-error residuals show process noise: {measured}; each held-out fold predicted by the filter tuned without it (κ per fold: {})",
            kappas.join(", ")
        ),
    })
}

/// A steady-state filter tuned on some samples: the likeliest process noise `κ` of [`KAPPAS`],
/// its gain, twice its log-likelihood gain over output error and the innovations' and output
/// error's mean squares on those samples.
struct Tuned {
    lr: f64,
    kappa: f64,
    k: DMatrix<f64>,
    b: [f64; NY],
    r_oe: [f64; NY],
}

/// The filter of the module doc tuned on the samples of `ranges` only, at the output-error
/// estimate `th` with residuals `e` (over the record): the noise levels, the linearisation and
/// `κ` all from those samples. `Err` says why no filter can be formed.
fn tune<D: Dynamics>(
    setup: &Setup<D>,
    spec: &Spec,
    th: &[f64],
    e: &[[f64; NY]],
    ranges: &[(usize, usize)],
) -> Result<Tuned, &'static str> {
    let within =
        |e: &[[f64; NY]]| -> Vec<[f64; NY]> { ranges.iter().flat_map(|&(a, b)| e[a..b].iter().copied()).collect() };
    let e_id = within(e);
    let r_oe = noise_of(&e_id);
    let n = e_id.len() as f64;
    let log_det = |e: &[[f64; NY]]| noise_of(e).iter().map(|b| b.ln()).sum::<f64>();
    let l_oe = log_det(&e_id);
    let (a, c) = setup
        .mean_jacobians(spec, th, ranges)
        .ok_or("the model cannot be linearised for a filter")?;
    let nx = a.nrows();
    // nalgebra's matrix exponential needs finite entries (it scales by the norm); a step that is
    // not finite and positive has no discrete model.
    let step_s = setup.step_s();
    if !(step_s.is_finite() && step_s > 0.0 && a.iter().all(|v| v.is_finite())) {
        return Err("the linearised model is not finite: no filter can be formed");
    }
    let phi = (a * step_s).exp();
    let r_meas = measurement_noise(setup, ranges, &r_oe);
    let mut best: Option<Tuned> = None;
    for kappa in KAPPAS {
        let qd = DMatrix::<f64>::from_fn(nx, nx, |i, j| if i == j { kappa * r_oe[i] } else { 0.0 });
        let Some(k) = steady_gain(&phi, &c, &qd, &r_meas) else {
            continue;
        };
        let Some(innovations) = setup.innovations(spec, th, &k) else {
            continue;
        };
        let innovations = within(&innovations);
        let lr = n * (l_oe - log_det(&innovations));
        if best.as_ref().is_none_or(|b| lr > b.lr) {
            best = Some(Tuned {
                lr,
                kappa,
                k,
                b: noise_of(&innovations),
                r_oe,
            });
        }
    }
    best.ok_or("no steady-state filter could be formed")
}

/// Each output's measurement-noise variance: its white-noise level per range of `ranges`,
/// pooled, kept between 10⁻⁶ and 1 times the output error's residual mean square `r_oe`.
fn measurement_noise<D: Dynamics>(setup: &Setup<D>, ranges: &[(usize, usize)], r_oe: &[f64; NY]) -> [f64; NY] {
    let y = setup.plant.y_m();
    core::array::from_fn(|i| {
        let (mut sum, mut len) = (0.0, 0.0);
        for &(a, b) in ranges {
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

    /// The filter that predicts a held-out fold is tuned on the other folds only: with the
    /// output-error residuals of the fold replaced by NaN, the tuning on the other folds' samples
    /// is finite and identical to the tuning with the residuals intact (the Fixture's 20 s flight
    /// in light turbulence at 10 Hz, 2 s blocks in 5 folds; fold 0 held out).
    #[test]
    fn the_filter_of_a_held_out_fold_does_not_read_its_residuals() {
        let fx = oem::tests::Fixture::new();
        let inp = fx.inputs();
        let setup = oem::setup(&inp).expect("the longitudinal plant");
        let base = oem::output_error_baseline(&inp, &setup).expect("the baseline fits");
        let id = setup.fold_ranges(0, false);
        let mut poisoned = base.e().to_vec();
        for (a, b) in setup.fold_ranges(0, true) {
            for r in &mut poisoned[a..b] {
                *r = [f64::NAN; NY];
            }
        }
        let blind = tune(&setup, base.spec(), base.th(), &poisoned, &id).expect("a filter");
        let seen = tune(&setup, base.spec(), base.th(), base.e(), &id).expect("a filter");
        assert!(
            blind.lr.is_finite() && blind.k.iter().all(|v| v.is_finite()),
            "{}",
            blind.k
        );
        assert_eq!(blind.kappa, seen.kappa);
        assert_eq!(blind.k, seen.k);
        assert_eq!(blind.r_oe, seen.r_oe);
    }

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
