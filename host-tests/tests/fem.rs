//! The filter error method (seed 001) in the core: Jacobians, refusal of bad input, and the real
//! HFB-320 flight data against the published filter-error estimates.

use aerosid::fem_report::{default_hfb320_path, hfb320_filter, step_data, PUBLISHED};
use aerosid_core::fem::models::{hfb320_idx, Hfb320, Longitudinal};
use aerosid_core::fem::{central_difference, FilterError, Model, Sensitivity};
use nalgebra::{SMatrix, SVector};

fn hfb320_rows() -> Vec<[f64; 20]> {
    aerosid::fem_report::hfb320_rows(&default_hfb320_path()).expect("HFB-320 data")
}

#[test]
fn hfb320_analytic_parameter_jacobians_match_central_differences() {
    let m = Hfb320::<f64>::default();
    let x = SVector::<f64, 4>::new(106.0, 0.11, 0.10, 0.01);
    let u = SVector::<f64, 2>::new(-0.05, 12_000.0);
    let p = SVector::<f64, 11>::from_column_slice(&PUBLISHED);
    let fd_f: SMatrix<f64, 4, 11> = central_difference(&p, |pp| m.f(&x, &u, pp));
    let fd_h: SMatrix<f64, 7, 11> = central_difference(&p, |pp| m.h(&x, &u, pp));
    // Linear in p: central differences are exact up to rounding (ε^{2/3} relative).
    let ef = (m.df_dp(&x, &u, &p) - fd_f).abs().max() / fd_f.abs().max();
    let eh = (m.dh_dp(&x, &u, &p) - fd_h).abs().max() / fd_h.abs().max();
    assert!(ef < 1e-9 && eh < 1e-9, "∂f/∂p {ef:e}, ∂h/∂p {eh:e}");
}

fn run_hfb320(filter: &mut FilterError<f64, Hfb320<f64>, 4, 2, 7, 11>) {
    for w in hfb320_rows().windows(2) {
        let (u, un, y) = step_data::<f64>(&w[0], &w[1]);
        filter.step(&u, &un, &y).expect("step");
    }
}

#[test]
fn hfb320_flight_data_against_the_published_filter_error_estimates() {
    // GIVEN the real HFB-320 flight (601 samples, 0.1 s, turbulence), the book's model, its noise
    // (Q = F Fᵀ, R) and starting values, the Bauer–Andrisani prior
    // WHEN the filter makes one recursive pass over the data (as on board), predicting as the book
    // does (RK4, the input averaged between samples), with the propagated sensitivity
    let mut fem = hfb320_filter::<f64>(&hfb320_rows(), Sensitivity::Propagated).expect("filter");
    run_hfb320(&mut fem);
    let (p, s) = (*fem.parameters(), fem.parameter_sigma());
    let z = |i: usize| (p[i] - PUBLISHED[i]).abs() / s[i];
    for i in 0..11 {
        println!(
            "{:>10} {:>+10.5} ± {:8.5}  published {:>+10.5}  {:5.2}σ",
            hfb320_idx::NAMES[i],
            p[i],
            s[i],
            PUBLISHED[i],
            z(i)
        );
    }
    // THEN ten of the eleven are within 2σ of the published filter-error values, Cmq among them
    // (measured −35.49 ± 0.82 vs −34.71, 0.94σ) …
    let cmalpha = 8;
    for i in (0..11).filter(|&i| i != cmalpha) {
        assert!(
            z(i) <= 2.0,
            "{}: {} vs {} ({:.2}σ)",
            hfb320_idx::NAMES[i],
            p[i],
            PUBLISHED[i],
            z(i)
        );
    }
    assert!(z(9) < 1.0, "Cmq {} ({:.2}σ)", p[9], z(9));
    // … and Cmα is just outside: −0.994 ± 0.012 vs −0.968 (measured 2.19σ). Why, not tuned away:
    // at 10 Hz the estimate depends on the prediction scheme by more than its σ (Euler → RK4 moves
    // Cmα by 4.5σ, RK4 → RK2 by 0.25σ: `hfb320_cmq_gap_is_the_prediction_at_10_hz`), and the noise
    // model is not the book's: with its F and R this filter predicts one-step errors larger than
    // the record's (`hfb320_book_noise_overpredicts_the_one_step_errors`) — the book's R is the
    // covariance of its residuals, used as the measurement noise of its steady-state Riccati
    // equation, so it weights the outputs differently from our `C P⁻ Cᵀ + R`. We keep the book's
    // integrator and noise rather than pick what passes (RK2 puts all eleven within 2σ). Bound at
    // the measured value plus a quarter σ, so a regression shows.
    assert!(z(cmalpha) < 2.45, "Cmα {} ({:.2}σ)", p[cmalpha], z(cmalpha));
}

#[test]
fn hfb320_cmq_gap_is_the_prediction_at_10_hz() {
    // GIVEN the same record and noise, WHEN the method runs with each prediction scheme
    // (aerosid::fem_report::VARIANTS), one recursive pass or batch Gauss–Newton
    let results = aerosid::fem_report::variants(&hfb320_rows()).expect("variants");
    let z = |k: usize, i: usize| (results[k].1[i] - PUBLISHED[i]).abs() / results[k].2[i];
    let cmq = 9;
    // THEN the paper's Euler prediction with the input held (eq. 3) is what put Cmq 4.3σ off
    // (measured −38.08), RK4 halves it (−36.36, 2.0σ), and the book's interpolated input closes
    // the rest (−35.49, 0.94σ): a zero-order hold lags the elevator by half a sample (50 ms),
    // which the fit turns into pitch damping …
    assert!(z(0, cmq) > 4.0, "Euler, held input: Cmq {:.2}σ", z(0, cmq));
    assert!(
        z(1, cmq) > 1.5 && z(1, cmq) < z(0, cmq),
        "RK4, held input: Cmq {:.2}σ",
        z(1, cmq)
    );
    assert!(z(2, cmq) < 1.0, "RK4, interpolated input: Cmq {:.2}σ", z(2, cmq));
    // … and one recursive pass is not the cause: the batch Gauss–Newton estimate with the same
    // filter differs from it by at most 0.15σ in every parameter (measured 0.14σ, CD0 and CDV).
    for i in 0..11 {
        let d = (results[3].1[i] - results[2].1[i]).abs() / results[2].2[i];
        assert!(d < 0.15, "{}: batch vs recursive {d:.3}σ", hfb320_idx::NAMES[i]);
    }
}

#[test]
fn hfb320_book_noise_overpredicts_the_one_step_errors() {
    // GIVEN the book's F and R in our filter (RK4, interpolated input, propagated sensitivity)
    // WHEN the mean squared one-step prediction error of each output is set against the mean of
    // its predicted variance C P⁻ Cᵀ + R
    let ratio = aerosid::fem_report::innovation_ratio(&hfb320_rows()).expect("ratio");
    println!("Δz² / predicted: {ratio:?}");
    // THEN every output's errors are smaller than predicted — V 0.52, α 0.66, θ 0.75, q 0.54,
    // q̇ 0.87, a_x 0.87, a_z 0.77 (measured): the filter weights V, α, q by up to 1.9× less than
    // their errors warrant. The book's F and R are a joint estimate within its own formulation
    // (R the residual covariance, a steady-state gain), not a noise model this filter takes over
    // unchanged.
    for (i, r) in ratio.iter().enumerate() {
        assert!((0.4..0.95).contains(r), "output {i}: {r}");
    }
}

#[test]
fn a_non_finite_measurement_is_refused_and_leaves_the_filter_untouched() {
    let mut fem = hfb320_filter::<f64>(&hfb320_rows(), Sensitivity::OneStep).expect("filter");
    let before = fem;
    let u = SVector::<f64, 2>::new(0.0, 10_000.0);
    let mut y = SVector::<f64, 7>::from_column_slice(&[106.0, 0.11, 0.1, 0.0, 0.0, 0.5, -9.8]);
    y[3] = f64::NAN;
    assert!(fem.step(&u, &u, &y).is_err());
    // THEN the state, the parameters and both covariances are bit-identical; only the counter moved
    assert_eq!(fem.state(), before.state());
    assert_eq!(fem.state_covariance(), before.state_covariance());
    assert_eq!(fem.parameters(), before.parameters());
    assert_eq!(fem.parameter_covariance(), before.parameter_covariance());
    assert_eq!(fem.health().refused_input, 1);
    assert_eq!(fem.health().steps, 0);
}

#[test]
fn longitudinal_model_solves_alpha_dot_consistently() {
    // α̇ returned by the model satisfies the implicit lift equation it came from.
    let mut m = Longitudinal::<f64>::a4d();
    m.thrust_n = 8_000.0;
    let x = SVector::<f64, 5>::new(236.0, 0.02, 0.01, 0.03, 10_000.0);
    let u = SVector::<f64, 1>::new(-0.01);
    let p = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_TRUE);
    let ad = m.alpha_dot(&x, &u, &p);
    let (v, alpha, q, theta) = (x[0], x[1], x[2], x[3]);
    let qs = 0.5 * m.rho_kgpm3 * v * v * m.wing_area_m2;
    let lift = qs * (p[0] + p[1] * alpha + p[2] * ad * m.chord_m / (2.0 * v) + p[3] * u[0]);
    let rhs = q - (lift + m.thrust_n * alpha.sin() - m.mass_kg * 9.80665 * (theta - alpha).cos()) / (m.mass_kg * v);
    assert!((ad - rhs).abs() < 1e-12, "{ad} vs {rhs}");
    assert_eq!(m.f(&x, &u, &p)[1], ad);
}

#[test]
fn hfb320_in_f32_agrees_with_f64_within_a_quarter_of_sigma() {
    // GIVEN the same data and settings in f32 (as on the MCU)
    let rows = hfb320_rows();
    let mut fem32 = hfb320_filter::<f32>(&rows, Sensitivity::Propagated).expect("filter");
    // WHEN it runs over the data (every step must be accepted)
    for w in rows.windows(2) {
        let (u, un, y) = step_data::<f32>(&w[0], &w[1]);
        fem32.step(&u, &un, &y).expect("f32 step");
    }
    let mut fem64 = hfb320_filter::<f64>(&rows, Sensitivity::Propagated).expect("filter");
    run_hfb320(&mut fem64);
    // THEN each parameter differs from the f64 run by less than a quarter of its σ — statistically
    // the same estimate (measured: at most 0.21σ, on CD0 and CDV: the f32 central-difference step
    // of the RK4 prediction in V is ε^{1/3}·106 m/s ≈ 0.5 m/s, and the P_p entries span eight
    // decades)
    let (p64, s64) = (fem64.parameters(), fem64.parameter_sigma());
    let mut worst = 0.0f64;
    for i in 0..11 {
        let d = (fem32.parameters()[i] as f64 - p64[i]).abs() / s64[i];
        println!(
            "{:>10}: f32 {:+.5} f64 {:+.5} ({d:.3}σ)",
            hfb320_idx::NAMES[i],
            fem32.parameters()[i],
            p64[i]
        );
        worst = worst.max(d);
    }
    assert!(worst < 0.25, "worst {worst:.3}σ");
}

#[test]
fn hfb320_report_fits_the_outputs_as_well_as_the_published_model() {
    // GIVEN, WHEN: the `aerosid fem-hfb320` report into a scratch folder
    let out = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../target/fem-hfb320");
    let (text, figures) = aerosid::fem_report::hfb320_report(&default_hfb320_path(), &out).expect("report");
    println!("{text}");
    // THEN both figures exist, and the identified model's open-loop simulation explains every output
    // within 0.01 of R² of the published model's (measured: V 0.523 vs 0.504, α 0.917 vs 0.920,
    // q 0.863 vs 0.861, q̇ 0.822 vs 0.821, a_z 0.708 vs 0.704)
    for f in &figures {
        assert!(f.exists(), "{}", f.display());
    }
    let r2: Vec<(f64, f64)> = text
        .lines()
        .skip_while(|l| !l.contains("R² pub."))
        .skip(1)
        .take(7)
        .map(|l| {
            let v: Vec<f64> = l
                .split_whitespace()
                .rev()
                .take(4)
                .filter_map(|t| t.parse().ok())
                .collect();
            (v[2], v[0]) // (R² ours, R² published)
        })
        .collect();
    assert_eq!(r2.len(), 7, "{text}");
    for (ours, published) in r2 {
        assert!(ours >= published - 0.01, "R² {ours} vs published {published}");
    }
}

/// The normal equations of one Gauss–Newton step, accumulated explicitly (the reference for
/// `FilterError::new_pass`): the state filter at `p_lin` (Euler, input held, the EKF of the
/// module doc), `H = C S + D` with `S` propagated with the gain held, and
/// `p = p_lin + (P₀⁻¹ + Σ Hᵀ R_p⁻¹ H)⁻¹ (Σ Hᵀ R_p⁻¹ Δz + P₀⁻¹ (p_prior − p_lin))`.
fn gauss_newton_step_reference(
    fem: &FilterError<f64, Hfb320<f64>, 4, 2, 7, 11>,
    p_lin: &SVector<f64, 11>,
    data: &[(SVector<f64, 2>, SVector<f64, 2>, SVector<f64, 7>)],
) -> (SVector<f64, 11>, SMatrix<f64, 11, 11>) {
    let (m, st) = (fem.model(), fem.settings());
    let (mut x, mut px) = (*fem.state(), *fem.state_covariance());
    let mut s = SMatrix::<f64, 4, 11>::zeros();
    let prior_inv = fem.parameter_covariance().try_inverse().expect("prior");
    let mut info = prior_inv;
    let mut grad = prior_inv * (fem.parameters() - p_lin);
    for (u, un, y) in data {
        let phi = SMatrix::<f64, 4, 4>::identity() + m.df_dx(&x, u, p_lin) * st.dt_s;
        let sp = phi * s + m.df_dp(&x, u, p_lin) * st.dt_s;
        let xp = x + m.f(&x, u, p_lin) * st.dt_s;
        let pp = phi * px * phi.transpose() + st.q_x * st.dt_s;
        let (c, d) = (m.dh_dx(&xp, un, p_lin), m.dh_dp(&xp, un, p_lin));
        let dz = y - m.h(&xp, un, p_lin);
        let rp_inv = (c * pp * c.transpose() + st.r_x).try_inverse().expect("R_p");
        let h = c * sp + d;
        info += h.transpose() * rp_inv * h;
        grad += h.transpose() * rp_inv * dz;
        let k = pp * c.transpose() * rp_inv;
        x = xp + k * dz;
        let ikc = SMatrix::<f64, 4, 4>::identity() - k * c;
        px = ikc * pp * ikc.transpose() + k * st.r_x * k.transpose();
        s = ikc * sp - k * d;
    }
    let cov = info.try_inverse().expect("information");
    (p_lin + cov * grad, cov)
}

#[test]
fn a_pass_is_the_gauss_newton_step_of_the_linearised_problem() {
    // GIVEN the HFB-320 record and filter (Euler, input held), a linearisation point away from the
    // prior mean (the published values; the prior at the book's starting values)
    let rows = hfb320_rows();
    let data: Vec<_> = rows.windows(2).map(|w| step_data::<f64>(&w[0], &w[1])).collect();
    let fem = aerosid::fem_report::hfb320_filter_with::<f64>(
        &rows,
        Sensitivity::Propagated,
        aerosid_core::fem::Integrator::Euler,
        aerosid_core::fem::InputHold::Zero,
    )
    .expect("filter");
    let p_lin = SVector::<f64, 11>::from_column_slice(&PUBLISHED);
    // WHEN one pass runs (the parameter filter a sequential Kalman filter on Δz − H(p̄ − p_lin))
    let mut pass = FilterError::new_pass(
        *fem.model(),
        *fem.settings(),
        *fem.state(),
        *fem.state_covariance(),
        p_lin,
        *fem.parameters(),
        *fem.parameter_covariance(),
    )
    .expect("pass");
    for (u, un, y) in &data {
        pass.step(u, un, y).expect("step");
    }
    assert_eq!(pass.linearisation_point(), Some(&p_lin));
    // THEN it equals the explicit normal equations of the same linearised problem: the estimate
    // within 10⁻⁶ σ and the covariance within 10⁻⁶ relative (sequential vs batch rounding of a
    // 600-step sum whose information spans eight decades; measured below 10⁻⁸)
    let (p_ref, cov_ref) = gauss_newton_step_reference(&fem, &p_lin, &data);
    for i in 0..11 {
        let sigma = cov_ref[(i, i)].sqrt();
        let dp = (pass.parameters()[i] - p_ref[i]).abs() / sigma;
        let dc = (pass.parameter_covariance()[(i, i)] / cov_ref[(i, i)] - 1.0).abs();
        assert!(dp < 1e-6 && dc < 1e-6, "{}: {dp:e}σ, {dc:e}", hfb320_idx::NAMES[i]);
    }
}

#[test]
fn a_pass_refuses_a_bad_linearisation_point_and_bad_samples_without_a_trace() {
    let rows = hfb320_rows();
    let fem = hfb320_filter::<f64>(&rows, Sensitivity::Propagated).expect("filter");
    let make = |p_lin: SVector<f64, 11>| {
        FilterError::new_pass(
            *fem.model(),
            *fem.settings(),
            *fem.state(),
            *fem.state_covariance(),
            p_lin,
            *fem.parameters(),
            *fem.parameter_covariance(),
        )
    };
    let mut bad = *fem.parameters();
    bad[3] = f64::NAN;
    assert!(make(bad).is_err());
    let mut pass = make(*fem.parameters()).expect("pass");
    let before = pass;
    let u = SVector::<f64, 2>::new(0.0, 10_000.0);
    let mut y = SVector::<f64, 7>::from_column_slice(&[106.0, 0.11, 0.1, 0.0, 0.0, 0.5, -9.8]);
    y[0] = f64::INFINITY;
    assert!(pass.step(&u, &u, &y).is_err());
    assert_eq!(pass.parameters(), before.parameters());
    assert_eq!(pass.state(), before.state());
    assert_eq!(pass.parameter_covariance(), before.parameter_covariance());
    assert_eq!(pass.health().refused_input, 1);
}

/// ẋ = u: the integrators' input hold is checked against the exact integral of a ramp.
struct Integrator1;
impl<T: aerosid_core::Real> Model<T, 1, 1, 1, 1> for Integrator1 {
    fn f(&self, _x: &SVector<T, 1>, u: &SVector<T, 1>, _p: &SVector<T, 1>) -> SVector<T, 1> {
        *u
    }
    fn h(&self, x: &SVector<T, 1>, _u: &SVector<T, 1>, _p: &SVector<T, 1>) -> SVector<T, 1> {
        *x
    }
}

fn input_hold_is_exact_for_a_ramp<T: aerosid_core::Real + std::fmt::Debug>() {
    use aerosid_core::fem::{integrate, InputHold, Integrator};
    let l = T::lit;
    let (x, u0, u1, p, dt) = (
        SVector::<T, 1>::new(l(1.0)),
        SVector::<T, 1>::new(l(2.0)),
        SVector::<T, 1>::new(l(4.0)),
        SVector::<T, 1>::new(l(0.0)),
        l(0.1),
    );
    // GIVEN ẋ = u with u ramping from 2 to 4 over the step: ∫u dt = 0.3, held: 0.2
    for (integrator, hold, expected) in [
        (Integrator::Euler, InputHold::Zero, 1.2),
        (Integrator::Euler, InputHold::Linear, 1.2),
        (Integrator::Rk2, InputHold::Zero, 1.2),
        (Integrator::Rk2, InputHold::Linear, 1.3),
        (Integrator::Rk4, InputHold::Zero, 1.2),
        (Integrator::Rk4, InputHold::Linear, 1.3),
    ] {
        // WHEN one step is taken, THEN the held input gives x + u₀Δt, the interpolated one the
        // exact x + (u₀ + u₁)Δt/2 (RK stages), Euler's single stage u₀ either way; to 4 ulp of 1.3
        let got = integrate::<T, Integrator1, 1, 1, 1, 1>(&Integrator1, integrator, hold, dt, &x, &u0, &u1, &p)[0];
        assert!(
            (got - l(expected)).abs() <= l(4.0 * 1.3) * T::EPS,
            "{integrator:?} {hold:?}: {got:?}"
        );
    }
}

#[test]
fn input_hold_is_exact_for_a_ramp_f32_and_f64() {
    input_hold_is_exact_for_a_ramp::<f32>();
    input_hold_is_exact_for_a_ramp::<f64>();
}

#[test]
fn dryden_gust_states_have_the_dryden_variance_poles_and_zero() {
    use aerosid_core::fem::models::LongitudinalDryden;
    // GIVEN the gust states of LongitudinalDryden (τ = V/L of the Table 1 simulation)
    let tau = 236.0 / 533.4;
    let m = LongitudinalDryden {
        base: Longitudinal::<f64>::a4d(),
        tau_u_per_s: tau,
        tau_w_per_s: tau,
    };
    let p = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_TRUE);
    let u = SVector::<f64, 1>::new(0.0);
    let x = SVector::<f64, 8>::from_column_slice(&[236.0, 0.02, 0.0, 0.02, 10_000.0, 0.0, 0.0, 0.0]);
    // WHEN the (w₁, w₂) block of ∂f/∂x and the output map w_g(w₁, w₂) are read off the model
    let a = Model::<f64, 8, 1, 5, 9>::df_dx(&m, &x, &u, &p)
        .fixed_view::<2, 2>(6, 6)
        .into_owned();
    let c = SVector::<f64, 2>::new(
        m.gust_w_mps(&{
            let mut e = x;
            e[6] = 1.0;
            e
        }),
        m.gust_w_mps(&{
            let mut e = x;
            e[7] = 1.0;
            e
        }),
    );
    // THEN the stationary covariance P = diag(1/(4τ³), 1/(4τ)) (unit intensity on w₂) solves
    // A P + P Aᵀ + B Bᵀ = 0 and gives var(w_g) = cᵀ P c = 1, i.e. σ_w² per unit intensity …
    let pc = SMatrix::<f64, 2, 2>::new(1.0 / (4.0 * tau.powi(3)), 0.0, 0.0, 1.0 / (4.0 * tau));
    let bbt = SMatrix::<f64, 2, 2>::new(0.0, 0.0, 0.0, 1.0);
    let lyap = a * pc + pc * a.transpose() + bbt;
    assert!(lyap.abs().max() < 1e-6, "{lyap}");
    assert!(((c.transpose() * pc * c)[(0, 0)] - 1.0).abs() < 1e-6);
    // … the double pole is at −τ (trace −2τ, determinant τ²) and the zero of w_g/ω_w at −τ/√3
    // (c = τ^{3/2}·[1, √3/τ]: numerator c₂ s + c₁): Dryden's (1 + √3 L s/V)/(1 + L s/V)²
    assert!((a.trace() + 2.0 * tau).abs() < 1e-6 && (a.determinant() - tau * tau).abs() < 1e-6);
    assert!((-c[0] / c[1] + tau / 3f64.sqrt()).abs() < 1e-9);
    // … and with no gust the model is the plain longitudinal one (outputs and dynamics)
    let x5 = SVector::<f64, 5>::from_column_slice(&[236.0, 0.02, 0.0, 0.02, 10_000.0]);
    let f8 = Model::<f64, 8, 1, 6, 9>::f(&m, &x, &u, &p);
    let f5 = m.base.f(&x5, &u, &p);
    assert_eq!(f8.fixed_rows::<5>(0).into_owned(), f5);
    let y = Model::<f64, 8, 1, 6, 9>::h(&m, &x, &u, &p);
    assert_eq!(y[5], m.base.specific_force_z(&x5, &u, &p));
}

#[test]
fn hfb320_pass_in_f32_agrees_with_f64_within_a_quarter_of_sigma() {
    // GIVEN one Gauss–Newton pass over the record linearised at the f64 recursive estimate (where
    // the batch iteration ends up: within 0.15σ of it, `hfb320_cmq_gap_is_the_prediction_at_10_hz`),
    // in f32 and in f64
    let rows = hfb320_rows();
    let mut rec = hfb320_filter::<f64>(&rows, Sensitivity::Propagated).expect("filter");
    run_hfb320(&mut rec);
    let p_lin = *rec.parameters();
    let fem32 = hfb320_filter::<f32>(&rows, Sensitivity::Propagated).expect("filter");
    let mut pass32 = FilterError::new_pass(
        *fem32.model(),
        *fem32.settings(),
        *fem32.state(),
        *fem32.state_covariance(),
        p_lin.map(|v| v as f32),
        *fem32.parameters(),
        *fem32.parameter_covariance(),
    )
    .expect("pass");
    for w in rows.windows(2) {
        let (u, un, y) = step_data::<f32>(&w[0], &w[1]);
        pass32.step(&u, &un, &y).expect("f32 step");
    }
    let fem64 = hfb320_filter::<f64>(&rows, Sensitivity::Propagated).expect("filter");
    let mut pass64 = FilterError::new_pass(
        *fem64.model(),
        *fem64.settings(),
        *fem64.state(),
        *fem64.state_covariance(),
        p_lin,
        *fem64.parameters(),
        *fem64.parameter_covariance(),
    )
    .expect("pass");
    run_hfb320(&mut pass64);
    // THEN every parameter agrees within a quarter of its σ, the budget of the recursive filter
    // (`hfb320_in_f32_agrees_with_f64_within_a_quarter_of_sigma`; measured 0.14σ). (Linearised at
    // the book's starting values instead, 25–50 % off, the pass is a long linear extrapolation and
    // f32 rounding reaches 0.37σ; that first step of an iteration is not its result.)
    let (p64, s64) = (pass64.parameters(), pass64.parameter_sigma());
    let worst = (0..11)
        .map(|i| (f64::from(pass32.parameters()[i]) - p64[i]).abs() / s64[i])
        .fold(0.0, f64::max);
    println!("f32 pass: worst {worst:.3}σ");
    assert!(worst < 0.25, "worst {worst:.3}σ");
}
