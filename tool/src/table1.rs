//! Seed 001's example (Section 4, Table 1) on a simulator of its own model: the A-4D longitudinal
//! model ([`Longitudinal::a4d`]) with Table 1's true parameters, Dryden turbulence as process noise,
//! white measurement noise, an elevator multistep, and the filter error method started from Table 1's
//! ±15 % initial values with Bauer & Andrisani's prior.
//!
//! The truth integrates the model with RK4 at [`INTERNAL_DT_S`] with the aerodynamics evaluated at the
//! air-relative state: `V_a = V − u_g`, `α_a = α + w_g/V` (Dryden gusts, MIL-F-8785C above
//! 2 000 ft: `L = 1 750 ft`, light `σ = 1 m/s`, the gust held over each sample), while `θ̇ = q` and
//! `ḣ = V sin(θ − α)` stay inertial. The measurements are the inertial states (`V, α, q, θ, h` as
//! from an INS/air-data blend) and the body-z specific force (an accelerometer), plus white noise,
//! so the gusts are *process* noise for the filter, as in the paper. The α̇ of the `CLα̇`, `Cmα̇`
//! terms is the model's own (the gust's `ẇ_g/V` is not added).
//!
//! Four estimators run on the same flights ([`Method`]): the paper's (one recursive pass, one-step
//! sensitivity, the turbulence as white process noise, the five states measured); ours on board
//! (one recursive pass, the gusts as Dryden-shaped filter states, the accelerometer as a sixth
//! output, the sensitivity propagated through the state filter); ours offline (the same filter,
//! batch Gauss–Newton over the record, [`crate::fem_batch`]); and seed 000's equation-error
//! PCA-GTLS. [`cramer_rao`] gives the information the record holds on each parameter.

use crate::fem_batch::{self, Sample, StateStart};
use crate::sim::{Dryden, Turbulence};
use aerosid_core::fem::models::{Longitudinal, LongitudinalDryden};
use aerosid_core::fem::{bauer_andrisani, FemSettings, FilterError, InputHold, Integrator, Model, Sensitivity};
use nalgebra::{SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use rayon::prelude::*;
use std::fmt::Write as _;

/// Sample period of the measurements and the filter, s (50 Hz).
pub const DT_S: f64 = 0.02;
/// Truth integration step, s.
pub const INTERNAL_DT_S: f64 = 0.005;
/// Flight condition: true airspeed, m/s (Mach 0.8 at 35 000 ft).
pub const V0_MPS: f64 = 236.0;
/// Altitude, m.
pub const H0_M: f64 = 10_668.0;
/// Turbulence intensity of the truth (Dryden, all three axes), m/s: light.
pub const GUST_SIGMA_MPS: f64 = 1.0;
/// Turbulence scale length (MIL-F-8785C above 2 000 ft: 1 750 ft), m.
pub const GUST_LENGTH_M: f64 = 533.4;
/// Accelerometer noise (1σ), m/s².
pub const AZ_NOISE_MPS2: f64 = 0.05;
/// Measurement noise (1σ) of `V, α, q, θ, h` (m/s, rad, rad/s, rad, m).
pub const NOISE: [f64; 5] = [0.3, 0.002, 0.002, 0.002, 1.0];
/// Runs per campaign.
pub const RUNS: u64 = 50;
/// Names of the nine parameters, Table 1's order.
pub const NAMES: [&str; 9] = Longitudinal::<f64>::NAMES;

/// The elevator input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Input {
    /// A 3-2-1-1 multistep of `step_s` per unit and `amplitude_rad`, from 1 s.
    Multistep3211 {
        /// Unit step duration, s.
        step_s: f64,
        /// Amplitude, rad.
        amplitude_rad: f64,
    },
}

impl Input {
    /// The paper's kind of input, our stand-in for its Fig. 5 multistep (whose timing is not
    /// printed): a 3-2-1-1 of 0.4 s units, 1° (15 s record).
    pub const PAPER: Input = Input::Multistep3211 {
        step_s: 0.4,
        amplitude_rad: 0.0175,
    };
    /// The designed input: the same amplitude, the unit chosen by the Cramér–Rao scan of
    /// `aerosid table1` ([`design_scan`]) to minimise the bound on `Cmα̇` and `Cmq` (30 s record).
    pub const DESIGNED: Input = Input::Multistep3211 {
        step_s: DESIGNED_STEP_S,
        amplitude_rad: 0.0175,
    };

    /// Deflection increment at `t_s`.
    pub fn elevator_rad(&self, t_s: f64) -> f64 {
        match *self {
            Input::Multistep3211 { step_s, amplitude_rad } => {
                let k = (t_s - 1.0) / step_s;
                if !(0.0..7.0).contains(&k) {
                    0.0
                } else if k < 3.0 || (5.0..6.0).contains(&k) {
                    amplitude_rad
                } else {
                    -amplitude_rad
                }
            }
        }
    }

    /// A short label.
    pub fn label(&self) -> String {
        match *self {
            Input::Multistep3211 { step_s, amplitude_rad } => {
                format!("3-2-1-1, {step_s} s units, {:.1}°", amplitude_rad.to_degrees())
            }
        }
    }
}

/// The unit of [`Input::DESIGNED`], s (from [`design_scan`]).
pub const DESIGNED_STEP_S: f64 = 4.0;
/// Record length with the paper's input, s.
pub const PAPER_SECONDS: f64 = 15.0;
/// Record length with the designed input, s.
pub const DESIGNED_SECONDS: f64 = 30.0;

/// One simulated flight: inputs `u(t_k)` and measurements `y(t_k)`.
#[derive(Debug, Clone)]
pub struct Flight {
    /// Elevator deflection per sample.
    pub u: Vec<f64>,
    /// Measurements `V, α, q, θ, h` per sample.
    pub y: Vec<[f64; 5]>,
    /// Measured body-z specific force per sample (accelerometer, noise [`AZ_NOISE_MPS2`]), m/s².
    pub az: Vec<f64>,
    /// The trim state.
    pub x0: [f64; 5],
    /// The model with its trim thrust.
    pub model: Longitudinal<f64>,
}

/// Trim of the model at [`V0_MPS`], level: `(α, δe, T)`.
pub fn trim(p: &SVector<f64, 9>) -> (f64, f64, f64) {
    let mut m = Longitudinal::<f64>::a4d();
    let (mut alpha, mut de, mut thrust) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..50 {
        m.thrust_n = thrust;
        let qs = 0.5 * m.rho_kgpm3 * V0_MPS * V0_MPS * m.wing_area_m2;
        // Lift + thrust·sin α = weight; moment zero; thrust·cos α = drag.
        let weight = m.mass_kg * 9.80665;
        let cl = (weight - thrust * alpha.sin()) / qs;
        de = -(p[4] + p[5] * alpha) / p[8];
        alpha = (cl - p[0] - p[3] * de) / p[1];
        de = -(p[4] + p[5] * alpha) / p[8];
        thrust = qs * (m.cd0 + m.cd_alpha * alpha) / alpha.cos();
    }
    (alpha, de, thrust)
}

/// One sample period of the truth (module doc) from `x` with the gust `g` (body u, v, w) held: RK4
/// at [`INTERNAL_DT_S`].
fn truth_step(
    model: &Longitudinal<f64>,
    p: &SVector<f64, 9>,
    u: &SVector<f64, 1>,
    g: &nalgebra::Vector3<f64>,
    x: &SVector<f64, 5>,
) -> SVector<f64, 5> {
    let truth = |x: &SVector<f64, 5>| {
        let mut xa = *x;
        xa[0] = x[0] - g[0];
        xa[1] = x[1] + g[2] / x[0];
        let mut d = model.f(&xa, u, p);
        d[3] = x[2];
        d[4] = x[0] * (x[3] - x[1]).sin();
        d
    };
    let h = INTERNAL_DT_S;
    let mut x = *x;
    for _ in 0..(DT_S / INTERNAL_DT_S).round() as usize {
        let k1 = truth(&x);
        let k2 = truth(&(x + k1 * (h / 2.0)));
        let k3 = truth(&(x + k2 * (h / 2.0)));
        let k4 = truth(&(x + k3 * h));
        x += (k1 + (k2 + k3) * 2.0 + k4) * (h / 6.0);
    }
    x
}

/// The truth at trim: the true parameters, the model with its trim thrust, the trim state and
/// elevator, and the seeded Dryden gusts (MIL-F-8785C above 2 000 ft, light).
struct Truth {
    p: SVector<f64, 9>,
    model: Longitudinal<f64>,
    x_trim: SVector<f64, 5>,
    de0: f64,
    gust: Dryden,
}

impl Truth {
    fn at_trim(seed: u64) -> Self {
        let p = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_TRUE);
        let (alpha0, de0, thrust) = trim(&p);
        let mut model = Longitudinal::<f64>::a4d();
        model.thrust_n = thrust;
        let turb = Turbulence {
            lengths_m: [GUST_LENGTH_M; 3],
            sigma_mps: [GUST_SIGMA_MPS; 3],
        };
        Self {
            p,
            model,
            x_trim: SVector::<f64, 5>::new(V0_MPS, alpha0, 0.0, alpha0, H0_M),
            de0,
            gust: Dryden::new(&turb, V0_MPS, DT_S, seed),
        }
    }
}

/// Simulates `seconds` of flight with the true parameters, `input`, light turbulence, seeded.
pub fn simulate(input: Input, seconds: f64, seed: u64) -> Flight {
    let Truth {
        p,
        model,
        x_trim: mut x,
        de0,
        mut gust,
    } = Truth::at_trim(seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0007_AB1E_0001);
    let x0 = [x[0], x[1], x[2], x[3], x[4]];
    let mut g_prev = gust.gust_body_mps();
    let n = (seconds / DT_S).round() as usize;
    let (mut us, mut ys, mut azs) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
    for k in 0..n {
        let t = k as f64 * DT_S;
        let u = SVector::<f64, 1>::new(de0 + input.elevator_rad(t));
        let mut y = [0.0; 5];
        for (i, yi) in y.iter_mut().enumerate() {
            let e: f64 = rng.sample(StandardNormal);
            *yi = x[i] + NOISE[i] * e;
        }
        us.push(u[0]);
        ys.push(y);
        let xa = SVector::<f64, 5>::new(x[0] - g_prev[0], x[1] + g_prev[2] / x[0], x[2], x[3], x[4]);
        let e: f64 = rng.sample(StandardNormal);
        azs.push(model.specific_force_z(&xa, &u, &p) + AZ_NOISE_MPS2 * e);
        let g = gust.step();
        g_prev = g;
        x = truth_step(&model, &p, &u, &g, &x);
    }
    Flight {
        u: us,
        y: ys,
        az: azs,
        x0,
        model,
    }
}

/// The filter's process-noise spectral density `Q_x` (per second): the covariance of the truth's
/// one-step model residual `(x_{k+1} − x_k)/Δt − f(x_k)` on a noise-free calibration flight (seed
/// `u64::MAX`) times `Δt` — what a flight-test engineer sets from the residuals, as the paper says
/// ("adjusted using the residuals as guideline"). Diagonal.
pub fn process_noise() -> SMatrix<f64, 5, 5> {
    // A calibration flight without measurement noise: the residual of the *measured* states would
    // contain the noise, so the truth is integrated here.
    let Truth {
        p,
        model,
        x_trim: mut x,
        de0,
        mut gust,
    } = Truth::at_trim(u64::MAX);
    let u = SVector::<f64, 1>::new(de0);
    let mut sum = SVector::<f64, 5>::zeros();
    let n = 20_000;
    for _ in 0..n {
        let g = gust.step();
        let x_prev = x;
        x = truth_step(&model, &p, &u, &g, &x);
        let r = (x - x_prev) / DT_S - model.f(&x_prev, &u, &p);
        sum += r.component_mul(&r);
    }
    SMatrix::<f64, 5, 5>::from_diagonal(&(sum / n as f64 * DT_S))
}

/// The result of one identification run.
#[derive(Debug, Clone, Copy)]
pub struct Run {
    /// Estimates, Table 1's order.
    pub p: [f64; 9],
    /// Their σ.
    pub sigma: [f64; 9],
    /// Their covariance (row-major).
    pub covariance: [[f64; 9]; 9],
}

impl Run {
    fn from_estimate(p: &SVector<f64, 9>, cov: &SMatrix<f64, 9, 9>) -> Self {
        Self {
            p: core::array::from_fn(|j| p[j]),
            sigma: core::array::from_fn(|j| cov[(j, j)].max(0.0).sqrt()),
            covariance: core::array::from_fn(|i| core::array::from_fn(|j| cov[(i, j)])),
        }
    }
}

/// An estimator of the campaign (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// The paper's: one recursive pass, Euler (eq. 3), one-step sensitivity (eq. 6), the
    /// turbulence as white process noise ([`process_noise`]), the five states measured.
    Paper,
    /// Ours on board: one recursive pass of [`LongitudinalDryden`] (the gusts as Dryden-shaped
    /// states, the accelerometer as a sixth output), RK4, the propagated sensitivity.
    Recursive,
    /// Ours offline: the same filter, batch Gauss–Newton over the record ([`fem_batch`]).
    Batch,
    /// Seed 000's equation-error PCA-GTLS ([`identify_equation_error`]).
    EquationError,
}

impl Method {
    /// All four, in table order.
    pub const ALL: [Method; 4] = [Method::Paper, Method::Recursive, Method::Batch, Method::EquationError];

    /// A short label.
    pub fn label(&self) -> &'static str {
        match self {
            Method::Paper => "paper's FEM (1 pass, white Q, 1-step H)",
            Method::Recursive => "ours on board (1 pass, Dryden states + a_z)",
            Method::Batch => "ours offline (Gauss-Newton, same filter)",
            Method::EquationError => "equation-error PCA-GTLS (seed 000)",
        }
    }
}

/// Table 1's initial values and the Bauer–Andrisani prior `diag((0.25 p̄)²)` with σ 0.01 for `Cm0`
/// (the paper's Table 2: `P₀ = 10⁻⁴`).
pub fn prior() -> (SVector<f64, 9>, SMatrix<f64, 9, 9>) {
    let p0 = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_INITIAL);
    (p0, bauer_andrisani(&p0, 0.01))
}

/// The paper's filter: [`Longitudinal`] with the states measured, `Q_x` from [`process_noise`],
/// `R_x` the measurement noise, Euler, one-step sensitivity, `x̂₀ = y₀`, `P_x0 = R_x`.
fn paper_filter(flight: &Flight, q_x: &SMatrix<f64, 5, 5>) -> StateStart<Longitudinal<f64>, 5, 5> {
    let r_x = SMatrix::<f64, 5, 5>::from_diagonal(&SVector::from_fn(|i, _| NOISE[i] * NOISE[i]));
    StateStart {
        model: flight.model,
        settings: FemSettings {
            q_x: *q_x,
            r_x,
            dt_s: DT_S,
            integrator: Integrator::Euler,
            input_hold: InputHold::Zero,
            sensitivity: Sensitivity::OneStep,
        },
        x0: SVector::<f64, 5>::from_column_slice(&flight.y[0]),
        p_x0: r_x,
    }
}

/// Our filter: [`LongitudinalDryden`] with the truth's gust model (`τ = V₀/L`, `σ` 1 m/s: `Q` is
/// `2σ²τ` on `u_g` and `σ²` on `w₂`, 10⁻⁸ on the flight states), the accelerometer as a sixth
/// output, RK4 with the input held (as the truth holds it), the propagated sensitivity; the flight
/// states start at the first measurement with the measurement noise as covariance, the gusts at zero
/// with their stationary covariance.
pub fn dryden_filter(flight: &Flight) -> StateStart<LongitudinalDryden<f64>, 8, 6> {
    dryden_filter_in(flight, &Conditions::SIMULATED)
}

/// Noise levels relative to the simulated ones, for the question "what would it take":
/// [`cramer_rao`] with the filter's noise model scaled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conditions {
    /// Scale of the measurement noise σ of `V, α, q, θ, h`.
    pub state_noise: f64,
    /// Scale of the accelerometer noise σ.
    pub accelerometer_noise: f64,
    /// Scale of the turbulence intensity σ_u, σ_w.
    pub turbulence: f64,
}

impl Conditions {
    /// The simulated flights: [`NOISE`], [`AZ_NOISE_MPS2`], [`GUST_SIGMA_MPS`].
    pub const SIMULATED: Conditions = Conditions {
        state_noise: 1.0,
        accelerometer_noise: 1.0,
        turbulence: 1.0,
    };

    /// A short label.
    pub fn label(&self) -> String {
        format!(
            "states ×{}, a_z ×{}, turbulence ×{}",
            self.state_noise, self.accelerometer_noise, self.turbulence
        )
    }
}

/// [`dryden_filter`] with the noise model scaled by `c`.
pub fn dryden_filter_in(flight: &Flight, c: &Conditions) -> StateStart<LongitudinalDryden<f64>, 8, 6> {
    let noise = |i: usize| {
        if i < 5 {
            NOISE[i] * c.state_noise
        } else {
            AZ_NOISE_MPS2 * c.accelerometer_noise
        }
    };
    let sigma2 = (GUST_SIGMA_MPS * c.turbulence).powi(2);
    let tau = V0_MPS / GUST_LENGTH_M;
    let q_x = SMatrix::<f64, 8, 8>::from_diagonal(&SVector::from_fn(|i, _| match i {
        5 => 2.0 * sigma2 * tau,
        6 => 0.0,
        7 => sigma2,
        _ => 1e-8,
    }));
    // The stationary covariance of the gust states: σ² for u_g; σ²·diag(1/(4τ³), 1/(4τ)) for
    // (w₁, w₂), the solution of A P + P Aᵀ + B Bᵀσ² = 0 for the controllable form.
    let p_x0 = SMatrix::<f64, 8, 8>::from_diagonal(&SVector::from_fn(|i, _| match i {
        5 => sigma2,
        6 => sigma2 / (4.0 * tau * tau * tau),
        7 => sigma2 / (4.0 * tau),
        _ => noise(i) * noise(i),
    }));
    StateStart {
        model: LongitudinalDryden {
            base: flight.model,
            tau_u_per_s: tau,
            tau_w_per_s: tau,
        },
        settings: FemSettings {
            q_x,
            r_x: SMatrix::<f64, 6, 6>::from_diagonal(&SVector::from_fn(|i, _| noise(i) * noise(i))),
            dt_s: DT_S,
            integrator: Integrator::Rk4,
            input_hold: InputHold::Zero,
            sensitivity: Sensitivity::Propagated,
        },
        x0: SVector::<f64, 8>::from_fn(|i, _| if i < 5 { flight.y[0][i] } else { 0.0 }),
        p_x0,
    }
}

/// The flight as filter steps `(u(t), u(t + Δt), y(t + Δt))` with `NY` = 5 (the states) or 6 (and
/// the accelerometer).
pub fn steps<const NY: usize>(flight: &Flight) -> Vec<Sample<1, NY>> {
    (0..flight.y.len().saturating_sub(1))
        .map(|k| {
            (
                SVector::<f64, 1>::new(flight.u[k]),
                SVector::<f64, 1>::new(flight.u[k + 1]),
                SVector::<f64, NY>::from_fn(|i, _| if i < 5 { flight.y[k + 1][i] } else { flight.az[k + 1] }),
            )
        })
        .collect()
}

/// One recursive pass from the prior; with `history`, the estimate after every step is appended.
fn recursive<M, const NX: usize, const NY: usize>(
    start: &StateStart<M, NX, NY>,
    data: &[Sample<1, NY>],
    mut history: Option<&mut Vec<Run>>,
) -> Option<Run>
where
    M: Model<f64, NX, 1, NY, 9> + Copy,
{
    let (p0, p_p0) = prior();
    let mut fem = FilterError::new(start.model, start.settings, start.x0, start.p_x0, p0, p_p0).ok()?;
    for (u, un, y) in data {
        fem.step(u, un, y).ok()?;
        if let Some(h) = history.as_deref_mut() {
            h.push(Run::from_estimate(fem.parameters(), fem.parameter_covariance()));
        }
    }
    Some(Run::from_estimate(fem.parameters(), fem.parameter_covariance()))
}

/// Gauss–Newton iterations of the batch method: at most this many passes.
pub const BATCH_MAX_ITERATIONS: usize = 10;
/// … stopping when a step moves every parameter by less than this fraction of its σ.
pub const BATCH_TOLERANCE_SIGMA: f64 = 0.01;

/// Identifies the nine parameters from `flight` with `method`, started from Table 1's initial values
/// with the Bauer–Andrisani prior. `None` if a filter refuses a step or the batch iteration does not
/// converge. With `history` (recursive methods), the estimate after every step is appended.
pub fn identify(flight: &Flight, method: Method, history: Option<&mut Vec<Run>>) -> Option<Run> {
    match method {
        Method::Paper => recursive(
            &paper_filter(flight, process_noise_cached()),
            &steps::<5>(flight),
            history,
        ),
        Method::Recursive => recursive(&dryden_filter(flight), &steps::<6>(flight), history),
        Method::Batch => {
            let (p0, p_p0) = prior();
            let fit = fem_batch::gauss_newton(
                &dryden_filter(flight),
                &p0,
                &p0,
                &p_p0,
                &steps::<6>(flight),
                BATCH_MAX_ITERATIONS,
                BATCH_TOLERANCE_SIGMA,
            )?;
            fit.converged.then(|| Run::from_estimate(&fit.p, &fit.covariance))
        }
        Method::EquationError => Some(identify_equation_error(flight)),
    }
}

/// [`process_noise`], computed once.
fn process_noise_cached() -> &'static SMatrix<f64, 5, 5> {
    static Q: std::sync::OnceLock<SMatrix<f64, 5, 5>> = std::sync::OnceLock::new();
    Q.get_or_init(process_noise)
}

/// The Cramér–Rao bound of the nine parameters for `input` over `seconds` (flight `seed`): the
/// inverse Fisher information of the record for [`dryden_filter_in`]'s model with the noise levels
/// `conditions`, at the true parameters, without the prior ([`fem_batch::cramer_rao`]). The flight
/// only sets the trajectory the model is linearised along; the noise enters through the filter.
pub fn cramer_rao(input: Input, seconds: f64, seed: u64, conditions: &Conditions) -> Option<SMatrix<f64, 9, 9>> {
    let flight = simulate(input, seconds, seed);
    let truth = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_TRUE);
    fem_batch::cramer_rao(
        &dryden_filter_in(&flight, conditions),
        &truth,
        &prior().1,
        &steps::<6>(&flight),
    )
}

/// What a campaign of [`RUNS`] flights gives.
#[derive(Debug, Clone)]
pub struct Summary {
    /// Runs identified (a refused or non-converged run is left out and counted here).
    pub runs: usize,
    /// Runs that failed.
    pub failed: usize,
    /// Posterior σ of CLα̇ over its prior σ, smallest over the runs.
    pub cl_alphadot_sigma_ratio_min: f64,
    /// Median over the runs of |relative error| (absolute for a zero truth).
    pub median_abs_rel_error: [f64; 9],
    /// Median over the runs of the |relative error| of `Cmα̇ + Cmq`, the combination the data
    /// determine ([`predicted_null_direction`]).
    pub median_abs_rel_error_cm_damping_sum: f64,
    /// Runs with all nine parameters within 2σ of the truth.
    pub all_within_2sigma: usize,
    /// The fraction of runs with all nine within 2σ that honest Gaussian σ would give: the mean
    /// over the runs of `P(|z_j| ≤ 2 ∀j)` for `z ~ N(0, corr)` with each run's correlation
    /// (seeded Monte Carlo, 4 000 draws per run).
    pub expected_all_within_2sigma: f64,
    /// Runs with each parameter within 2σ.
    pub per_param_within_2sigma: [usize; 9],
    /// Mean error over the runs.
    pub bias: [f64; 9],
    /// Standard deviation of the estimates over the runs.
    pub spread: [f64; 9],
    /// Mean σ over the runs.
    pub mean_sigma: [f64; 9],
    /// `√(mean z²)` with `z = (p̂ − p)/σ` per run: 1 for honest σ, above 1 when σ is too small.
    pub rms_z: [f64; 9],
    /// The run with the median sum of squared normalised errors.
    pub median_run: Run,
}

/// [`RUNS`] seeded flights (seeds 1…[`RUNS`]) of `seconds` with `input`, identified by `method`.
pub fn campaign(input: Input, seconds: f64, method: Method) -> Summary {
    let runs: Vec<Option<Run>> = (1..=RUNS)
        .into_par_iter()
        .map(|seed| identify(&simulate(input, seconds, seed), method, None))
        .collect();
    let failed = runs.iter().filter(|r| r.is_none()).count();
    let runs: Vec<Run> = runs.into_iter().flatten().collect();
    let mut s = summarise(&runs);
    s.failed = failed;
    s
}

/// The statistics of `runs` against Table 1's truth.
pub fn summarise(runs: &[Run]) -> Summary {
    let truth = Longitudinal::<f64>::TABLE1_TRUE;
    let prior_cl_alphadot = prior().1[(2, 2)].sqrt();
    let n = runs.len().max(1) as f64;
    let within = |r: &Run, j: usize| (r.p[j] - truth[j]).abs() <= 2.0 * r.sigma[j];
    let err = |r: &Run, j: usize| r.p[j] - truth[j];
    let mut s = Summary {
        runs: runs.len(),
        failed: 0,
        cl_alphadot_sigma_ratio_min: runs
            .iter()
            .map(|r| r.sigma[2] / prior_cl_alphadot)
            .fold(f64::INFINITY, f64::min),
        median_abs_rel_error: [f64::NAN; 9],
        median_abs_rel_error_cm_damping_sum: f64::NAN,
        all_within_2sigma: runs.iter().filter(|r| (0..9).all(|j| within(r, j))).count(),
        expected_all_within_2sigma: runs.iter().map(honest_all_within_2sigma).sum::<f64>() / n,
        per_param_within_2sigma: core::array::from_fn(|j| runs.iter().filter(|r| within(r, j)).count()),
        bias: core::array::from_fn(|j| runs.iter().map(|r| err(r, j)).sum::<f64>() / n),
        spread: [0.0; 9],
        mean_sigma: core::array::from_fn(|j| runs.iter().map(|r| r.sigma[j]).sum::<f64>() / n),
        rms_z: core::array::from_fn(|j| {
            (runs.iter().map(|r| (err(r, j) / r.sigma[j]).powi(2)).sum::<f64>() / n).sqrt()
        }),
        median_run: runs.first().copied().unwrap_or(Run {
            p: [f64::NAN; 9],
            sigma: [f64::NAN; 9],
            covariance: [[f64::NAN; 9]; 9],
        }),
    };
    for j in 0..9 {
        let mean = s.bias[j] + truth[j];
        s.spread[j] = (runs.iter().map(|r| (r.p[j] - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
        let scale = if truth[j] != 0.0 { truth[j].abs() } else { 1.0 };
        let mut e: Vec<f64> = runs.iter().map(|r| (err(r, j) / scale).abs()).collect();
        e.sort_by(|a, b| a.total_cmp(b));
        if !e.is_empty() {
            s.median_abs_rel_error[j] = e[e.len() / 2];
        }
    }
    let sum_truth = truth[6] + truth[7];
    let mut e: Vec<f64> = runs
        .iter()
        .map(|r| ((r.p[6] + r.p[7] - sum_truth) / sum_truth).abs())
        .collect();
    e.sort_by(|a, b| a.total_cmp(b));
    if !e.is_empty() {
        s.median_abs_rel_error_cm_damping_sum = e[e.len() / 2];
    }
    let mut order: Vec<(f64, usize)> = runs
        .iter()
        .enumerate()
        .map(|(i, r)| ((0..9).map(|j| (err(r, j) / r.sigma[j]).powi(2)).sum::<f64>(), i))
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let Some(&(_, i)) = order.get(order.len() / 2) {
        s.median_run = runs[i];
    }
    s
}

/// `P(|z_j| ≤ 2 ∀j)` for `z ~ N(0, corr)` with the run's correlation, by 4 000 seeded draws; 0 if
/// the covariance has no Cholesky factor (a NaN σ of the equation-error method).
fn honest_all_within_2sigma(r: &Run) -> f64 {
    let corr = SMatrix::<f64, 9, 9>::from_fn(|i, j| r.covariance[i][j] / (r.sigma[i] * r.sigma[j]));
    let Some(chol) = corr.cholesky() else {
        return 0.0;
    };
    let l = chol.l();
    let mut rng = ChaCha8Rng::seed_from_u64(0x0007_AB1E_2516);
    let draws = 4000;
    let hits = (0..draws)
        .filter(|_| {
            let n = SVector::<f64, 9>::from_fn(|_, _| rng.sample(StandardNormal));
            (l * n).iter().all(|z| z.abs() <= 2.0)
        })
        .count();
    hits as f64 / draws as f64
}

/// `|e|` of a parameter as a percentage of its truth, or absolute for a zero truth.
fn rel(j: usize, v: f64) -> String {
    let t = Longitudinal::<f64>::TABLE1_TRUE[j];
    if t != 0.0 {
        format!("{:6.1}%", 100.0 * ((v - t) / t).abs())
    } else {
        format!("{:7.5}", (v - t).abs())
    }
}

/// One campaign as a table beside Table 1 of the seed: true, initial, the seed's estimate ± σ, the
/// median run's ± σ, the seed's error and our median error, and σ's honesty (mean σ, spread, rms z,
/// runs within 2σ).
pub fn summary_table(label: &str, s: &Summary) -> String {
    let mut out = String::new();
    let t = Longitudinal::<f64>::TABLE1_TRUE;
    let init = Longitudinal::<f64>::TABLE1_INITIAL;
    let (seed, seed_s) = (Longitudinal::<f64>::TABLE1_SEED, Longitudinal::<f64>::TABLE1_SEED_SIGMA);
    let expected = if s.mean_sigma.iter().any(|v| v.is_nan()) {
        "σ missing where the method gives none".to_string()
    } else {
        format!(
            "honest Gaussian σ would give {:.0} %",
            100.0 * s.expected_all_within_2sigma
        )
    };
    let _ = writeln!(
        out,
        "\n{label}: {} runs ({} failed); all nine within 2σ in {}/{} ({expected})",
        s.runs, s.failed, s.all_within_2sigma, s.runs
    );
    let _ = writeln!(
        out,
        "{:>10} {:>7} {:>7} {:>19} {:>21} {:>7} {:>7} {:>9} {:>9} {:>5} {:>6}",
        "param",
        "true",
        "initial",
        "seed ± σ",
        "ours (median run) ± σ",
        "seed e",
        "med. e",
        "mean σ",
        "spread",
        "rms z",
        "in 2σ"
    );
    for j in 0..9 {
        let m = &s.median_run;
        let _ = writeln!(
            out,
            "{:>10} {:>+7.3} {:>+7.3} {:>+9.5} ± {:7.5} {:>+10.5} ± {:8.5} {} {} {:9.5} {:9.5} {:5.2} {:>3}/{}",
            NAMES[j],
            t[j],
            init[j],
            seed[j],
            seed_s[j],
            m.p[j],
            m.sigma[j],
            rel(j, seed[j]),
            if t[j] != 0.0 {
                format!("{:6.1}%", 100.0 * s.median_abs_rel_error[j])
            } else {
                format!("{:7.5}", s.median_abs_rel_error[j])
            },
            s.mean_sigma[j],
            s.spread[j],
            s.rms_z[j],
            s.per_param_within_2sigma[j],
            s.runs
        );
    }
    out
}

/// The methods side by side: median |error| per parameter (% of the truth; absolute for `Cm0`),
/// runs with all nine within 2σ, and `rms z` of the data-determined parameters.
pub fn comparison_table(title: &str, rows: &[(Method, &Summary)]) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "\n{title}: median |error| per parameter (% of the truth; Cm0 absolute), all nine within 2σ"
    );
    let _ = write!(out, "{:>44}", "method");
    for name in NAMES {
        let _ = write!(out, " {name:>8}");
    }
    let _ = writeln!(out, " {:>9} {:>7}", "Cmα̇+Cmq", "in 2σ");
    for (method, s) in rows {
        let _ = write!(out, "{:>44}", method.label());
        for j in 0..9 {
            let v = s.median_abs_rel_error[j];
            if Longitudinal::<f64>::TABLE1_TRUE[j] != 0.0 {
                let _ = write!(out, " {:>7.1}%", 100.0 * v);
            } else {
                let _ = write!(out, " {v:>8.5}");
            }
        }
        let _ = writeln!(
            out,
            " {:>8.1}% {:>3}/{}",
            100.0 * s.median_abs_rel_error_cm_damping_sum,
            s.all_within_2sigma,
            s.runs
        );
    }
    let _ = write!(out, "{:>44}", "seed 001 (Table 1)");
    let (t, seed) = (Longitudinal::<f64>::TABLE1_TRUE, Longitudinal::<f64>::TABLE1_SEED);
    for j in 0..9 {
        let _ = write!(out, " {:>8}", rel(j, seed[j]).trim());
    }
    let _ = writeln!(
        out,
        " {:>8.1}%",
        100.0 * ((seed[6] + seed[7] - t[6] - t[7]) / (t[6] + t[7])).abs()
    );
    out
}

/// The Cramér–Rao bound of one input: σ per parameter, the bound on `Cmα̇ + Cmq`, and the largest
/// principal axis of the bound (the worst-determined combination).
#[derive(Debug, Clone, Copy)]
pub struct Bound {
    /// The input.
    pub input: Input,
    /// Record length, s.
    pub seconds: f64,
    /// The noise levels.
    pub conditions: Conditions,
    /// `σ_CRB` per parameter.
    pub sigma: [f64; 9],
    /// `σ_CRB` of `Cmα̇ + Cmq`.
    pub sigma_cm_damping_sum: f64,
    /// Correlation of `Cmα̇` and `Cmq` in the bound.
    pub corr_cmalphadot_cmq: f64,
    /// The unit eigenvector of the largest eigenvalue of the bound, scaled so that its `Cmα̇`
    /// component is 1 (Table 1's order).
    pub worst_direction: [f64; 9],
    /// Peak `|a_z − a_z(0)|` of the seed-1 flight (with turbulence and noise), m/s².
    pub peak_delta_az_mps2: f64,
}

/// [`cramer_rao`] of `input` over `seconds` (flight seed 1) as a [`Bound`].
pub fn bound(input: Input, seconds: f64, conditions: Conditions) -> Option<Bound> {
    let c = cramer_rao(input, seconds, 1, &conditions)?;
    let sym = nalgebra::SymmetricEigen::new(c);
    let k = (0..9).max_by(|&a, &b| sym.eigenvalues[a].total_cmp(&sym.eigenvalues[b]))?;
    let v = sym.eigenvectors.column(k);
    let flight = simulate(input, seconds, 1);
    let az0 = flight.az[0];
    Some(Bound {
        input,
        seconds,
        conditions,
        sigma: core::array::from_fn(|j| c[(j, j)].sqrt()),
        sigma_cm_damping_sum: (c[(6, 6)] + c[(7, 7)] + 2.0 * c[(6, 7)]).sqrt(),
        corr_cmalphadot_cmq: c[(6, 7)] / (c[(6, 6)] * c[(7, 7)]).sqrt(),
        worst_direction: core::array::from_fn(|j| v[j] / v[6]),
        peak_delta_az_mps2: flight.az.iter().map(|a| (a - az0).abs()).fold(0.0, f64::max),
    })
}

/// The direction in which the pitching-moment data carry no first-order information: with
/// `α̇ = q + A`, `A = α̇ − q = −(q̄S/(mV))(C_L0 + C_Lα α + C_Lδe δe + …) + (g/V) cos γ − …`, raising
/// `Cmα̇` by ε and lowering `Cmq` by ε changes `Cm` by `ε ĉ A` (`ĉ = c̄/(2V)`), which
/// `ΔCmα = ε ĉ Z_α` and `ΔCmδe = ε ĉ Z_δe` (`Z_x = q̄S C_Lx/(mV)`, 1/s) and a `ΔCm0` (≈ 0 at
/// trim, where the lift balances the weight) cancel to first order. Returns the direction in
/// Table 1's order scaled to `ΔCmα̇ = 1`: `[0, 0, 0, 0, 0, ĉZ_α, 1, −1, ĉZ_δe]`.
pub fn predicted_null_direction() -> [f64; 9] {
    let m = Longitudinal::<f64>::a4d();
    let t = Longitudinal::<f64>::TABLE1_TRUE;
    let qs_over_mv = 0.5 * m.rho_kgpm3 * V0_MPS * m.wing_area_m2 / m.mass_kg;
    let chat = m.chord_m / (2.0 * V0_MPS);
    [
        0.0,
        0.0,
        0.0,
        0.0,
        0.0,
        chat * qs_over_mv * t[1],
        1.0,
        -1.0,
        chat * qs_over_mv * t[3],
    ]
}

/// The 3-2-1-1 units scanned by [`design_scan`], s.
pub const DESIGN_UNITS_S: [f64; 10] = [0.2, 0.3, 0.4, 0.6, 0.8, 1.0, 1.5, 2.0, 3.0, 4.0];

/// The input design: the Cramér–Rao bound of 1° 3-2-1-1 inputs of each unit in [`DESIGN_UNITS_S`]
/// over [`DESIGNED_SECONDS`] (all the same length, so that only the shape differs). The designed
/// input is the unit that minimises `σ_CRB(Cmα̇)·σ_CRB(Cmq)` (the target pair).
pub fn design_scan() -> Vec<Bound> {
    DESIGN_UNITS_S
        .par_iter()
        .filter_map(|&step_s| {
            bound(
                Input::Multistep3211 {
                    step_s,
                    amplitude_rad: 0.0175,
                },
                DESIGNED_SECONDS,
                Conditions::SIMULATED,
            )
        })
        .collect()
}

/// The bounds as a table (relative σ; absolute for `Cm0`).
pub fn bound_table(bounds: &[Bound]) -> String {
    let mut out = String::new();
    let t = Longitudinal::<f64>::TABLE1_TRUE;
    let _ = writeln!(
        out,
        "\nCramér–Rao bound (no prior) per input, σ_CRB as % of the truth (Cm0 absolute); flight seed 1"
    );
    let _ = write!(out, "{:>34} {:>5}", "input", "T (s)");
    for name in NAMES {
        let _ = write!(out, " {name:>8}");
    }
    let _ = writeln!(out, " {:>9} {:>8} {:>7}", "Cmα̇+Cmq", "ρ(α̇,q)", "|Δaz|");
    for b in bounds {
        let _ = write!(out, "{:>34} {:>5.0}", b.input.label(), b.seconds);
        for j in 0..9 {
            if t[j] != 0.0 {
                let _ = write!(out, " {:>7.1}%", 100.0 * b.sigma[j] / t[j].abs());
            } else {
                let _ = write!(out, " {:>8.5}", b.sigma[j]);
            }
        }
        let _ = writeln!(
            out,
            " {:>8.1}% {:>8.4} {:>7.2}",
            100.0 * b.sigma_cm_damping_sum / (t[6] + t[7]).abs(),
            b.corr_cmalphadot_cmq,
            b.peak_delta_az_mps2
        );
    }
    out
}

/// The noise levels [`requirement_table`] tries: the simulated ones, a 10× better accelerometer,
/// all sensors 10× better, still air (turbulence ×0.01), and still air with 10× better sensors.
pub const WHAT_IT_TAKES: [Conditions; 5] = [
    Conditions::SIMULATED,
    Conditions {
        state_noise: 1.0,
        accelerometer_noise: 0.1,
        turbulence: 1.0,
    },
    Conditions {
        state_noise: 0.1,
        accelerometer_noise: 0.1,
        turbulence: 1.0,
    },
    Conditions {
        state_noise: 1.0,
        accelerometer_noise: 1.0,
        turbulence: 0.01,
    },
    Conditions {
        state_noise: 0.1,
        accelerometer_noise: 0.1,
        turbulence: 0.01,
    },
];

/// The bound `σ_CRB` below which an unbiased Gaussian estimate has a median |error| under 5 %:
/// the median of `|N(0, σ²)|` is `0.674σ`, so `σ < 5 %/0.674 = 7.4 %` of the truth.
pub const SIGMA_FOR_5_PERCENT_MEDIAN: f64 = 0.05 / 0.674_489_75;

/// [`bound`] of `CLα̇`, `Cmα̇`, `Cmq` for each of [`WHAT_IT_TAKES`] with both inputs.
pub fn requirement_bounds() -> Vec<Bound> {
    let cases: Vec<(Input, f64, Conditions)> = [(Input::PAPER, PAPER_SECONDS), (Input::DESIGNED, DESIGNED_SECONDS)]
        .iter()
        .flat_map(|&(i, s)| WHAT_IT_TAKES.iter().map(move |&c| (i, s, c)))
        .collect();
    cases.par_iter().filter_map(|&(i, s, c)| bound(i, s, c)).collect()
}

/// What it would take: the bounds of [`requirement_bounds`] as a table, beside the 7.4 % that a
/// 5 % median error needs.
pub fn requirement_table(bounds: &[Bound]) -> String {
    let mut out = String::new();
    let t = Longitudinal::<f64>::TABLE1_TRUE;
    let _ = writeln!(
        out,
        "
What it would take: σ_CRB (% of the truth) under other noise levels; a 5 % median error needs σ < {:.1} %",
        100.0 * SIGMA_FOR_5_PERCENT_MEDIAN
    );
    let _ = writeln!(
        out,
        "{:>34} {:>44} {:>9} {:>9} {:>9}",
        "input", "noise", "CLα̇", "Cmα̇", "Cmq"
    );
    for b in bounds {
        let _ = writeln!(
            out,
            "{:>34} {:>44} {:>8.1}% {:>8.1}% {:>8.1}%",
            b.input.label(),
            b.conditions.label(),
            100.0 * b.sigma[2] / t[2],
            100.0 * b.sigma[6] / t[6].abs(),
            100.0 * b.sigma[7] / t[7].abs()
        );
    }
    out
}

/// `aerosid table1 [--out DIR]`: the Cramér–Rao scan that designs the input, the four methods on
/// [`RUNS`] flights with the paper's input and with the designed one, each as a table beside
/// Table 1 and side by side, the weakest direction of the bound against the predicted one, and
/// the parameter histories ±σ of flight 1 (like the seed's Fig. 6–10) as SVG.
pub fn table1_report(out_dir: &std::path::Path) -> Result<(String, Vec<std::path::PathBuf>), String> {
    let mut out = String::new();
    let mut bounds = vec![bound(Input::PAPER, PAPER_SECONDS, Conditions::SIMULATED).ok_or("bound refused")?];
    bounds.extend(design_scan());
    out += &bound_table(&bounds);
    let predicted = predicted_null_direction();
    let _ = writeln!(
        out,
        "worst-determined direction of the bound (scaled to ΔCmα̇ = 1), paper's input: {}",
        fmt9(&bounds[0].worst_direction)
    );
    let _ = writeln!(
        out,
        "predicted first-order null direction (Cmα̇ ↑, Cmq ↓, Cmα by ĉZα, Cmδe by ĉZδe):  {}",
        fmt9(&predicted)
    );
    out += &requirement_table(&requirement_bounds());
    let mut figures = Vec::new();
    for (input, seconds) in [(Input::PAPER, PAPER_SECONDS), (Input::DESIGNED, DESIGNED_SECONDS)] {
        let summaries: Vec<(Method, Summary)> = Method::ALL.iter().map(|&m| (m, campaign(input, seconds, m))).collect();
        for (m, s) in &summaries {
            out += &summary_table(&format!("{}, {}, {seconds} s", m.label(), input.label()), s);
        }
        let rows: Vec<(Method, &Summary)> = summaries.iter().map(|(m, s)| (*m, s)).collect();
        out += &comparison_table(&format!("{}, {seconds} s", input.label()), &rows);
        figures.push(history_figure(input, seconds, out_dir)?);
    }
    Ok((out, figures))
}

fn fmt9(v: &[f64; 9]) -> String {
    v.iter().map(|x| format!("{x:+.5}")).collect::<Vec<_>>().join(" ")
}

/// The parameter histories ±σ of flight 1 by the paper's method and by ours on board.
fn history_figure(input: Input, seconds: f64, out_dir: &std::path::Path) -> Result<std::path::PathBuf, String> {
    use crate::plot::{Band, Colour, Figure, Line, Panel};
    let flight = simulate(input, seconds, 1);
    let (mut h_paper, mut h_ours) = (Vec::new(), Vec::new());
    identify(&flight, Method::Paper, Some(&mut h_paper)).ok_or("the paper's method refused a step")?;
    identify(&flight, Method::Recursive, Some(&mut h_ours)).ok_or("ours refused a step")?;
    let t: Vec<f64> = (1..=h_ours.len()).map(|k| k as f64 * DT_S).collect();
    let mut fig = Figure::new("t (s)").title(format!(
        "Seed 001 example (A-4D), {}, flight 1: parameter estimates ±σ",
        input.label()
    ));
    for j in 0..9 {
        let col = |h: &[Run], f: fn(&Run, usize) -> f64| h.iter().map(|r| f(r, j)).collect::<Vec<f64>>();
        let (po, so) = (col(&h_ours, |r, j| r.p[j]), col(&h_ours, |r, j| r.sigma[j]));
        let (pp, sp) = (col(&h_paper, |r, j| r.p[j]), col(&h_paper, |r, j| r.sigma[j]));
        let truth = vec![Longitudinal::<f64>::TABLE1_TRUE[j]; t.len()];
        fig = fig.panel(
            Panel::new(NAMES[j], NAMES[j])
                .band(Band::around("paper's ±σ", &t, &pp, &sp, 1.0, Colour::ORANGE))
                .band(Band::around("ours ±σ", &t, &po, &so, 1.0, Colour::BLUE))
                .line(Line::new("paper's method", &t, &pp, Colour::ORANGE))
                .line(Line::new("ours on board", &t, &po, Colour::BLUE))
                .line(Line::new("truth", &t, &truth, Colour::BLACK).dashed()),
        );
    }
    std::fs::create_dir_all(out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let Input::Multistep3211 { step_s, .. } = input;
    let path = out_dir.join(format!("table1_parameters_3211_{}ms.svg", (step_s * 1000.0).round()));
    fig.write_svg(&path).map_err(|e| format!("{e:?}"))?;
    Ok(path)
}

/// Seed 000's equation-error PCA-GTLS on the same flight, for the comparison of seed 001's Table 1: the lift and
/// pitching-moment coefficients are formed from the measurements sample by sample and regressed on
/// noisy regressors, with no model of the dynamics and no state filter.
///
/// * `C_L` from the accelerometer: `f_z = −q̄S(C_L cos α + C_D sin α)/m` (thrust along body x) with
///   the known drag polar, so `C_L = −(m f_z/(q̄S) + C_D sin α)/cos α`.
/// * `C_m = q̇ I_y/(q̄ S c̄)` with `q̇` the central difference of the measured `q`.
/// * Regressors `[1, δe]` exact (the elevator is known without error here), `[α, α̇ c̄/(2V), q c̄/(2V)]`
///   noisy, `α̇` the central difference of the measured `α`. A central difference's error
///   `(e_{k+1} − e_{k−1})/(2Δt)` is uncorrelated with the centre sample's `e_k`, so `W_T` (eq. 9) is
///   diagonal: `σ_α`, `σ_α̇ = σ_α/(√2 Δt)`, `σ_q̇ = σ_q/(√2 Δt)` (scaled into coefficient units), and
///   the output's noise from the accelerometer or from `q̇`.
/// * The weights of eq. 23 (the minimum-norm solution when a direction is not excited) are the
///   reciprocals of Table 1's initial values' magnitudes.
///
/// What this leaves out, on purpose (it is the comparison): the gusts. The aerodynamics see
/// `α + w_g/V` while the regressor is the inertial `α`, an error of `σ_w/V ≈ 0.004 rad` that is
/// coloured and not in `W_T`; the filter error method models it as process noise.
///
/// Returns the nine estimates in Table 1's order with their eq. 17 σ (NaN where the threshold of
/// eq. 21 left a direction unexcited, so that eq. 17 does not apply).
pub fn identify_equation_error(flight: &Flight) -> Run {
    use aerosid_core::estimator::Estimator;
    use aerosid_core::gtls::{Gtls, GtlsSettings};
    let m = &flight.model;
    let init = Longitudinal::<f64>::TABLE1_INITIAL;
    let w = |i: usize| 1.0 / init[i].abs().max(0.01);
    let n = flight.y.len();
    // Noise of each quantity (the simulator's; an engineer reads them off the sensor specs).
    let (s_alpha, s_q) = (NOISE[1], NOISE[2]);
    let s_rate = |s: f64| s / (2f64.sqrt() * DT_S);
    // Scales at the trim point, for W_T (the noise of a coefficient depends on q̄, c̄/(2V)).
    let v0 = flight.x0[0];
    let qbar_s0 = 0.5 * m.rho_kgpm3 * v0 * v0 * m.wing_area_m2;
    let chat0 = m.chord_m / (2.0 * v0);
    let s_cl = m.mass_kg * AZ_NOISE_MPS2 / qbar_s0;
    let s_cm = s_rate(s_q) * m.iy_kgm2 / (qbar_s0 * m.chord_m);
    let w_l = SMatrix::<f64, 3, 3>::from_diagonal(&SVector::from([
        s_alpha * s_alpha,
        (s_rate(s_alpha) * chat0).powi(2),
        s_cl * s_cl,
    ]));
    let w_m = SMatrix::<f64, 4, 4>::from_diagonal(&SVector::from([
        s_alpha * s_alpha,
        (s_rate(s_alpha) * chat0).powi(2),
        (s_q * chat0).powi(2),
        s_cm * s_cm,
    ]));
    // Regressor order [1, δe, α, α̇ĉ(, qĉ)]; Table 1's order [CL0, CLα, CLα̇, CLδe, Cm0, Cmα, Cmα̇, Cmq, Cmδe].
    let wl = SVector::<f64, 4>::from([1.0, w(3), w(1), w(2)]);
    let wm = SVector::<f64, 5>::from([1.0, w(8), w(5), w(6), w(7)]);
    let settings = GtlsSettings::default();
    let (Ok(mut lift), Ok(mut pitch)) = (
        Gtls::<f64, 4, 2, 3>::new(&w_l, &wl, settings),
        Gtls::<f64, 5, 2, 4>::new(&w_m, &wm, settings),
    ) else {
        return Run {
            p: [f64::NAN; 9],
            sigma: [f64::NAN; 9],
            covariance: [[f64::NAN; 9]; 9],
        };
    };
    for k in 1..n.saturating_sub(1) {
        let [v, alpha, q, _theta, _h] = flight.y[k];
        let de = flight.u[k];
        let qbar_s = 0.5 * m.rho_kgpm3 * v * v * m.wing_area_m2;
        let chat = m.chord_m / (2.0 * v);
        let alpha_dot = (flight.y[k + 1][1] - flight.y[k - 1][1]) / (2.0 * DT_S);
        let q_dot = (flight.y[k + 1][2] - flight.y[k - 1][2]) / (2.0 * DT_S);
        let cd = m.cd0 + m.cd_alpha * alpha;
        let cl = -(m.mass_kg * flight.az[k] / qbar_s + cd * alpha.sin()) / alpha.cos();
        let cm = q_dot * m.iy_kgm2 / (qbar_s * m.chord_m);
        // A refused sample leaves the estimator untouched; the campaign's data are all finite.
        let _ = lift.update(&SVector::from([1.0, de, alpha, alpha_dot * chat]), cl);
        let _ = pitch.update(&SVector::from([1.0, de, alpha, alpha_dot * chat, q * chat]), cm);
    }
    let (tl, tm) = (lift.theta(), pitch.theta());
    // Regressor slots of each Table 1 parameter: (estimator, slot); lift [1, δe, α, α̇ĉ], moment
    // [1, δe, α, α̇ĉ, qĉ].
    const SLOT: [(usize, usize); 9] = [(0, 0), (0, 2), (0, 3), (0, 1), (1, 0), (1, 2), (1, 3), (1, 4), (1, 1)];
    let (cl, cm) = (lift.covariance(), pitch.covariance());
    let cov = |a: usize, b: usize| -> f64 {
        let ((ea, sa), (eb, sb)) = (SLOT[a], SLOT[b]);
        match (ea, eb) {
            (0, 0) => cl.as_ref().map(|c| c[(sa, sb)]).unwrap_or(f64::NAN),
            (1, 1) => cm.as_ref().map(|c| c[(sa, sb)]).unwrap_or(f64::NAN),
            _ => 0.0,
        }
    };
    let p: [f64; 9] = core::array::from_fn(|j| {
        let (e, slot) = SLOT[j];
        if e == 0 {
            tl[slot]
        } else {
            tm[slot]
        }
    });
    Run {
        p,
        sigma: core::array::from_fn(|j| cov(j, j).sqrt()),
        covariance: core::array::from_fn(|a| core::array::from_fn(|b| cov(a, b))),
    }
}
