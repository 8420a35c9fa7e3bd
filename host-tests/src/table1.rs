//! Seed 001's example (Section 4, Table 1) on a simulator of its own model: the A-4D longitudinal
//! model ([`Longitudinal::a4d`]) with Table 1's true parameters, Dryden turbulence as process noise,
//! white measurement noise, an elevator multistep, and the filter error method started from Table 1's
//! ±15 % initial values with Bauer & Andrisani's prior.
//!
//! The truth integrates the model with RK4 at [`INTERNAL_DT_S`] with the aerodynamics evaluated at the
//! air-relative state: `V_a = V − u_g`, `α_a = α + w_g/V` (Dryden gusts, MIL-F-8785C above
//! 2 000 ft: `L = 1 750 ft`, light `σ = 1 m/s`), while `θ̇ = q` and `ḣ = V sin(θ − α)` stay inertial. The
//! measurements are the inertial states (`V, α, q, θ, h` as from an INS/air-data blend) plus white
//! noise, so the gusts are *process* noise for the filter, as in the paper. The α̇ of the
//! `CLα̇`, `Cmα̇` terms is the model's own (the gust's `ẇ_g/V` is not added).

use crate::sim::{Dryden, Turbulence};
use aerosid_core::fem::models::{Longitudinal, LongitudinalGust};
use aerosid_core::fem::{bauer_andrisani, FemSettings, FilterError, Integrator, Model, Sensitivity};
use nalgebra::{SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;

/// Sample period of the measurements and the filter, s (50 Hz).
pub const DT_S: f64 = 0.02;
/// Truth integration step, s.
pub const INTERNAL_DT_S: f64 = 0.005;
/// Flight condition: true airspeed, m/s (Mach 0.8 at 35 000 ft).
pub const V0_MPS: f64 = 236.0;
/// Altitude, m.
pub const H0_M: f64 = 10_668.0;
/// Measurement noise (1σ) of `V, α, q, θ, h`.
pub const NOISE: [f64; 5] = [0.3, 0.002, 0.002, 0.002, 1.0];

/// The elevator input.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Input {
    /// A 3-2-1-1 multistep of `step_s` per unit and `amplitude_rad`, from 1 s (our stand-in for the
    /// paper's Fig. 5 multistep, whose timing is not printed): `step_s = 0.4`, `0.0175` rad.
    Multistep3211 {
        /// Unit step duration, s.
        step_s: f64,
        /// Amplitude, rad.
        amplitude_rad: f64,
    },
    /// Two 3-2-1-1 of different units back to back (short period and slower), designed to separate
    /// `α̇` from `q`: `α̇ − q` is the normal acceleration, which a slow pulse excites without pitch
    /// rate and a fast one with it.
    DualMultistep {
        /// Amplitude, rad.
        amplitude_rad: f64,
    },
}

impl Input {
    /// The paper's kind of input (see [`Input::Multistep3211`]).
    pub const PAPER: Input = Input::Multistep3211 {
        step_s: 0.4,
        amplitude_rad: 0.0175,
    };

    /// Deflection increment at `t_s`.
    pub fn elevator_rad(&self, t_s: f64) -> f64 {
        let m3211 = |t: f64, dt: f64, a: f64| {
            let k = t / dt;
            if !(0.0..7.0).contains(&k) {
                0.0
            } else if k < 3.0 {
                a
            } else if k < 5.0 {
                -a
            } else if k < 6.0 {
                a
            } else {
                -a
            }
        };
        match *self {
            Input::Multistep3211 { step_s, amplitude_rad } => m3211(t_s - 1.0, step_s, amplitude_rad),
            Input::DualMultistep { amplitude_rad } => {
                m3211(t_s - 1.0, 0.3, amplitude_rad) + m3211(t_s - 5.0, 1.0, 0.6 * amplitude_rad)
            }
        }
    }
}

/// One simulated flight: inputs `u(t_k)` and measurements `y(t_k)`.
#[derive(Debug, Clone)]
pub struct Flight {
    /// Elevator deflection per sample.
    pub u: Vec<f64>,
    /// Measurements `V, α, q, θ, h` per sample.
    pub y: Vec<[f64; 5]>,
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

/// Simulates `seconds` of flight with the true parameters, `input`, light turbulence, seeded.
pub fn simulate(input: Input, seconds: f64, seed: u64) -> Flight {
    let p = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_TRUE);
    let (alpha0, de0, thrust) = trim(&p);
    let mut model = Longitudinal::<f64>::a4d();
    model.thrust_n = thrust;
    let turb = Turbulence {
        lengths_m: [533.4; 3],
        sigma_mps: [1.0; 3],
    };
    let mut gust = Dryden::new(&turb, V0_MPS, DT_S, seed);
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x0007_AB1E_0001);
    let mut x = SVector::<f64, 5>::new(V0_MPS, alpha0, 0.0, alpha0, H0_M);
    let x0 = [x[0], x[1], x[2], x[3], x[4]];
    let n = (seconds / DT_S).round() as usize;
    let (mut us, mut ys) = (Vec::with_capacity(n), Vec::with_capacity(n));
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
        let g = gust.step();
        x = truth_step(&model, &p, &u, &g, &x);
    }
    Flight {
        u: us,
        y: ys,
        x0,
        model,
    }
}

/// The filter's process-noise spectral density `Q_x` (per second): the covariance of the truth's
/// one-step model residual `(x_{k+1} − x_k)/Δt − f(x_k)` on a noise-free calibration flight (seed
/// `u64::MAX`) times `Δt` — what a flight-test engineer sets from the residuals, as the paper says
/// ("adjusted using the residuals as guideline"). Diagonal.
pub fn process_noise() -> SMatrix<f64, 5, 5> {
    let p = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_TRUE);
    // A calibration flight without measurement noise: reuse `simulate` and remove nothing — the
    // residual of the *measured* states would contain the noise, so integrate the truth here.
    let (alpha0, de0, thrust) = trim(&p);
    let mut model = Longitudinal::<f64>::a4d();
    model.thrust_n = thrust;
    let turb = Turbulence {
        lengths_m: [533.4; 3],
        sigma_mps: [1.0; 3],
    };
    let mut gust = Dryden::new(&turb, V0_MPS, DT_S, u64::MAX);
    let mut x = SVector::<f64, 5>::new(V0_MPS, alpha0, 0.0, alpha0, H0_M);
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
    /// Estimates.
    pub p: [f64; 9],
    /// Their σ.
    pub sigma: [f64; 9],
}

/// Identifies the nine parameters from `flight` with the filter error method started from Table 1's
/// initial values; `P₀ = diag((0.25 p̄)²)` with σ 0.01 for `Cm0` (the paper's `P₀ = 10⁻⁴`).
pub fn identify(flight: &Flight, q_x: &SMatrix<f64, 5, 5>, sensitivity: Sensitivity) -> Option<Run> {
    let r_x = SMatrix::<f64, 5, 5>::from_diagonal(&SVector::from_fn(|i, _| NOISE[i] * NOISE[i]));
    let settings = FemSettings {
        q_x: *q_x,
        r_x,
        dt_s: DT_S,
        integrator: Integrator::Euler,
        sensitivity,
    };
    let p0 = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_INITIAL);
    let x0 = SVector::<f64, 5>::from_column_slice(&flight.y[0]);
    let fem = FilterError::new(flight.model, settings, x0, r_x, p0, bauer_andrisani(&p0, 0.01)).ok()?;
    run_filter(fem, flight)
}

/// Runs `fem` over `flight`; every step must be accepted.
fn run_filter<M: Model<f64, NX, 1, 5, 9>, const NX: usize>(
    mut fem: FilterError<f64, M, NX, 1, 5, 9>,
    flight: &Flight,
) -> Option<Run> {
    for k in 0..flight.y.len() - 1 {
        let u = SVector::<f64, 1>::new(flight.u[k]);
        let un = SVector::<f64, 1>::new(flight.u[k + 1]);
        let y = SVector::<f64, 5>::from_column_slice(&flight.y[k + 1]);
        fem.step(&u, &un, &y).ok()?;
    }
    let mut run = Run {
        p: [0.0; 9],
        sigma: [0.0; 9],
    };
    run.p.copy_from_slice(fem.parameters().as_slice());
    run.sigma.copy_from_slice(fem.parameter_sigma().as_slice());
    Some(run)
}

/// [`identify`] with the gusts as filter states ([`LongitudinalGust`], L = 533 m, the Dryden gust
/// intensity 1 m/s: `Q = 2σ²V/L` on the gust states, `q_small` on the flight states).
pub fn identify_with_gust_states(flight: &Flight, q_small: f64, sensitivity: Sensitivity) -> Option<Run> {
    let r_x = SMatrix::<f64, 5, 5>::from_diagonal(&SVector::from_fn(|i, _| NOISE[i] * NOISE[i]));
    let l = 533.4;
    let qg = 2.0 * 1.0 * V0_MPS / l;
    let q_x = SMatrix::<f64, 7, 7>::from_diagonal(&SVector::from_fn(|i, _| if i >= 5 { qg } else { q_small }));
    let settings = FemSettings {
        q_x,
        r_x: r_x.fixed_view::<5, 5>(0, 0).into(),
        dt_s: DT_S,
        integrator: Integrator::Euler,
        sensitivity,
    };
    let model = LongitudinalGust {
        base: flight.model,
        length_u_m: l,
        length_w_m: l,
    };
    let p0 = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_INITIAL);
    let mut x0 = SVector::<f64, 7>::zeros();
    for i in 0..5 {
        x0[i] = flight.y[0][i];
    }
    let p_x0 =
        SMatrix::<f64, 7, 7>::from_diagonal(&SVector::from_fn(|i, _| if i >= 5 { 1.0 } else { NOISE[i] * NOISE[i] }));
    let fem = FilterError::new(model, settings, x0, p_x0, p0, bauer_andrisani(&p0, 0.01)).ok()?;
    run_filter(fem, flight)
}
