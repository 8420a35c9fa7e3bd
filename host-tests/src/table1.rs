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
use aerosid_core::fem::models::{Longitudinal, LongitudinalGust, LongitudinalGustAz};
use aerosid_core::fem::{bauer_andrisani, FemSettings, FilterError, Integrator, Model, Sensitivity};
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
/// Accelerometer noise (1σ), m/s².
pub const AZ_NOISE_MPS2: f64 = 0.05;
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
            lengths_m: [533.4; 3],
            sigma_mps: [1.0; 3],
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
    /// Estimates.
    pub p: [f64; 9],
    /// Their σ.
    pub sigma: [f64; 9],
}

/// Identifies the nine parameters from `flight` with the filter error method started from Table 1's
/// initial values; `P₀ = diag((0.25 p̄)²)` with σ 0.01 for `Cm0` (the paper's `P₀ = 10⁻⁴`).
pub fn identify(
    flight: &Flight,
    q_x: &SMatrix<f64, 5, 5>,
    sensitivity: Sensitivity,
    history: Option<&mut Vec<Run>>,
) -> Option<Run> {
    let r_x = SMatrix::<f64, 5, 5>::from_diagonal(&SVector::from_fn(|i, _| NOISE[i] * NOISE[i]));
    let x0 = SVector::<f64, 5>::from_column_slice(&flight.y[0]);
    let measured = |k: usize| SVector::<f64, 5>::from_column_slice(&flight.y[k]);
    run_filter(flight.model, *q_x, r_x, x0, r_x, sensitivity, flight, measured, history)
}

/// Builds the filter (Table 1's initial values, the Bauer–Andrisani prior with σ 0.01 for `Cm0`)
/// and runs it over `flight`, `measured(k)` giving `y(t_k)`; every step must be accepted. With
/// `history`, the estimate after every step is appended to it.
#[allow(clippy::too_many_arguments)]
fn run_filter<M: Model<f64, NX, 1, NY, 9>, const NX: usize, const NY: usize>(
    model: M,
    q_x: SMatrix<f64, NX, NX>,
    r_x: SMatrix<f64, NY, NY>,
    x0: SVector<f64, NX>,
    p_x0: SMatrix<f64, NX, NX>,
    sensitivity: Sensitivity,
    flight: &Flight,
    measured: impl Fn(usize) -> SVector<f64, NY>,
    mut history: Option<&mut Vec<Run>>,
) -> Option<Run> {
    let settings = FemSettings {
        q_x,
        r_x,
        dt_s: DT_S,
        integrator: Integrator::Euler,
        sensitivity,
    };
    let p0 = SVector::<f64, 9>::from_column_slice(&Longitudinal::<f64>::TABLE1_INITIAL);
    let mut fem = FilterError::new(model, settings, x0, p_x0, p0, bauer_andrisani(&p0, 0.01)).ok()?;
    let snapshot = |fem: &FilterError<f64, M, NX, 1, NY, 9>| {
        let mut run = Run {
            p: [0.0; 9],
            sigma: [0.0; 9],
        };
        run.p.copy_from_slice(fem.parameters().as_slice());
        run.sigma.copy_from_slice(fem.parameter_sigma().as_slice());
        run
    };
    for k in 0..flight.y.len() - 1 {
        let u = SVector::<f64, 1>::new(flight.u[k]);
        let un = SVector::<f64, 1>::new(flight.u[k + 1]);
        fem.step(&u, &un, &measured(k + 1)).ok()?;
        if let Some(h) = history.as_deref_mut() {
            h.push(snapshot(&fem));
        }
    }
    Some(snapshot(&fem))
}

/// Gust scale length of the filter's gust states, m (the truth's Dryden length).
const GUST_LENGTH_M: f64 = 533.4;

/// The gust model of the filter and its noise: the gust states' `Q = 2σ²V/L` (σ = 1 m/s),
/// `q_small` on the flight states; the state and its covariance start at the first measurement
/// and zero gust with σ 1 m/s.
fn gust_filter(
    flight: &Flight,
    q_small: f64,
) -> (
    LongitudinalGust<f64>,
    SMatrix<f64, 7, 7>,
    SVector<f64, 7>,
    SMatrix<f64, 7, 7>,
) {
    let qg = 2.0 * V0_MPS / GUST_LENGTH_M;
    let q_x = SMatrix::<f64, 7, 7>::from_diagonal(&SVector::from_fn(|i, _| if i >= 5 { qg } else { q_small }));
    let x0 = SVector::<f64, 7>::from_fn(|i, _| if i < 5 { flight.y[0][i] } else { 0.0 });
    let p_x0 =
        SMatrix::<f64, 7, 7>::from_diagonal(&SVector::from_fn(|i, _| if i >= 5 { 1.0 } else { NOISE[i] * NOISE[i] }));
    let model = LongitudinalGust {
        base: flight.model,
        length_u_m: GUST_LENGTH_M,
        length_w_m: GUST_LENGTH_M,
    };
    (model, q_x, x0, p_x0)
}

/// [`identify`] with the gusts as filter states ([`LongitudinalGust`], L = 533 m, the Dryden gust
/// intensity 1 m/s: `Q = 2σ²V/L` on the gust states, `q_small` on the flight states).
pub fn identify_with_gust_states(
    flight: &Flight,
    q_small: f64,
    sensitivity: Sensitivity,
    history: Option<&mut Vec<Run>>,
) -> Option<Run> {
    let r_x = SMatrix::<f64, 5, 5>::from_diagonal(&SVector::from_fn(|i, _| NOISE[i] * NOISE[i]));
    let (model, q_x, x0, p_x0) = gust_filter(flight, q_small);
    let measured = |k: usize| SVector::<f64, 5>::from_column_slice(&flight.y[k]);
    run_filter(model, q_x, r_x, x0, p_x0, sensitivity, flight, measured, history)
}

/// Runs per campaign.
pub const RUNS: u64 = 50;

/// What a campaign of [`RUNS`] flights gives.
#[derive(Debug, Clone, Copy)]
pub struct Summary {
    /// Posterior σ of CLα̇ over its prior σ, smallest over the runs.
    pub cl_alphadot_sigma_ratio_min: f64,
    /// Median over the runs of |relative error| (absolute for a zero truth).
    pub median_abs_rel_error: [f64; 9],
    /// Runs with all nine parameters within 2σ of the truth.
    pub all_within_2sigma: usize,
    /// Runs with each parameter within 2σ.
    pub per_param_within_2sigma: [usize; 9],
    /// Mean σ over the runs.
    pub mean_sigma: [f64; 9],
    /// Standard deviation of the estimates over the runs.
    pub spread: [f64; 9],
    /// The run with the median sum of squared normalised errors.
    pub median_run: Run,
}

/// [`RUNS`] seeded flights of `seconds` with `input`, identified with `sensitivity`, the gusts as
/// filter states or as white process noise.
pub fn campaign(input: Input, seconds: f64, sensitivity: Sensitivity, gust_states: bool) -> Summary {
    campaign_by(
        input,
        seconds,
        sensitivity,
        if gust_states { Filter::GustStates } else { Filter::White },
    )
}

/// Which filter a campaign runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Filter {
    /// Turbulence as white process noise, states measured (the paper).
    White,
    /// Gusts as filter states ([`identify_with_gust_states`]).
    GustStates,
    /// Gusts as filter states and a z accelerometer ([`identify_with_accelerometer`]).
    Accelerometer,
    /// Not a filter: seed 000's equation-error PCA-GTLS ([`identify_equation_error`]), for the
    /// comparison; the sensitivity setting does not apply to it.
    EquationError,
}

/// [`campaign`] with any [`Filter`].
pub fn campaign_by(input: Input, seconds: f64, sensitivity: Sensitivity, filter: Filter) -> Summary {
    let q = process_noise();
    let runs: Vec<Run> = (1..=RUNS)
        .into_par_iter()
        .map(|seed| {
            let f = simulate(input, seconds, seed);
            match filter {
                Filter::GustStates => identify_with_gust_states(&f, 1e-8, sensitivity, None),
                Filter::Accelerometer => identify_with_accelerometer(&f, 1e-8, sensitivity),
                Filter::White => identify(&f, &q, sensitivity, None),
                Filter::EquationError => Some(identify_equation_error(&f)),
            }
            .expect("every step accepted")
        })
        .collect();
    let truth = Longitudinal::<f64>::TABLE1_TRUE;
    let prior = 0.25 * Longitudinal::<f64>::TABLE1_INITIAL[2];
    let mut s = Summary {
        cl_alphadot_sigma_ratio_min: runs.iter().map(|r| r.sigma[2] / prior).fold(f64::INFINITY, f64::min),
        median_abs_rel_error: [0.0; 9],
        all_within_2sigma: 0,
        per_param_within_2sigma: [0; 9],
        mean_sigma: [0.0; 9],
        spread: [0.0; 9],
        median_run: runs[0],
    };
    for r in &runs {
        let mut all = true;
        for j in 0..9 {
            let ok = (r.p[j] - truth[j]).abs() <= 2.0 * r.sigma[j];
            all &= ok;
            s.per_param_within_2sigma[j] += ok as usize;
            s.mean_sigma[j] += r.sigma[j] / RUNS as f64;
        }
        s.all_within_2sigma += all as usize;
    }
    for j in 0..9 {
        let mean = runs.iter().map(|r| r.p[j]).sum::<f64>() / RUNS as f64;
        s.spread[j] = (runs.iter().map(|r| (r.p[j] - mean).powi(2)).sum::<f64>() / (RUNS - 1) as f64).sqrt();
        let mut e: Vec<f64> = runs
            .iter()
            .map(|r| {
                if truth[j] != 0.0 {
                    ((r.p[j] - truth[j]) / truth[j]).abs()
                } else {
                    (r.p[j] - truth[j]).abs()
                }
            })
            .collect();
        e.sort_by(|a, b| a.total_cmp(b));
        s.median_abs_rel_error[j] = e[e.len() / 2];
    }
    // The median run: median of the summed squared normalised errors.
    let mut order: Vec<(f64, usize)> = runs
        .iter()
        .enumerate()
        .map(|(i, r)| {
            (
                (0..9).map(|j| ((r.p[j] - truth[j]) / r.sigma[j]).powi(2)).sum::<f64>(),
                i,
            )
        })
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    s.median_run = runs[order[order.len() / 2].1];
    s
}

/// The campaign as a table beside Table 1 of the seed.
pub fn summary_table(label: &str, s: &Summary) -> String {
    let mut out = String::new();
    let t = Longitudinal::<f64>::TABLE1_TRUE;
    let init = Longitudinal::<f64>::TABLE1_INITIAL;
    let (seed, seed_s) = (Longitudinal::<f64>::TABLE1_SEED, Longitudinal::<f64>::TABLE1_SEED_SIGMA);
    let _ = writeln!(
        out,
        "\n{label}: {RUNS} runs; all nine within 2σ in {}/{RUNS}",
        s.all_within_2sigma
    );
    let _ = writeln!(
        out,
        "{:>11} {:>8} {:>8} {:>20} {:>20} {:>8} {:>8} {:>7} {:>7} {:>6}",
        "param", "true", "initial", "seed ± σ", "ours (median) ± σ", "seed err", "our err", "mean σ", "spread", "in 2σ"
    );
    for j in 0..9 {
        let rel = |v: f64| {
            if t[j] != 0.0 {
                format!("{:7.1}%", 100.0 * ((v - t[j]) / t[j]).abs())
            } else {
                format!("{:8.5}", (v - t[j]).abs())
            }
        };
        let _ = writeln!(
            out,
            "{:>11} {:>+8.4} {:>+8.4} {:>+10.5} ± {:7.5} {:>+10.5} ± {:7.5} {} {} {:7.4} {:7.4} {:>4}/{RUNS}",
            Longitudinal::<f64>::NAMES[j],
            t[j],
            init[j],
            seed[j],
            seed_s[j],
            s.median_run.p[j],
            s.median_run.sigma[j],
            rel(seed[j]),
            rel(s.median_run.p[j]),
            s.mean_sigma[j],
            s.spread[j],
            s.per_param_within_2sigma[j]
        );
    }
    let _ = writeln!(out, "median |rel. error| per parameter: {:.3?}", s.median_abs_rel_error);
    out
}

/// `aerosid table1 [--out DIR]`: the campaign with the paper's input by the paper's method
/// (one-step sensitivity, turbulence as white process noise) and by ours (propagated sensitivity,
/// gusts as filter states), as tables beside Table 1, and the parameter histories ±σ of seed 1
/// (like the seed's Fig. 6–10) as SVG.
pub fn table1_report(out_dir: &std::path::Path) -> Result<(String, Vec<std::path::PathBuf>), String> {
    use crate::plot::{Band, Colour, Figure, Line, Panel};
    let mut out = String::new();
    let paper = campaign(Input::PAPER, 15.0, Sensitivity::OneStep, false);
    out += &summary_table(
        "the paper's method (one-step sensitivity, white process noise), 3-2-1-1",
        &paper,
    );
    let ours = campaign(Input::PAPER, 15.0, Sensitivity::Propagated, true);
    out += &summary_table("ours (propagated sensitivity, gust states), 3-2-1-1", &ours);
    let flight = simulate(Input::PAPER, 15.0, 1);
    let (mut h_paper, mut h_ours) = (Vec::new(), Vec::new());
    identify(&flight, &process_noise(), Sensitivity::OneStep, Some(&mut h_paper))
        .ok_or("paper's method refused a step")?;
    identify_with_gust_states(&flight, 1e-8, Sensitivity::Propagated, Some(&mut h_ours))
        .ok_or("ours refused a step")?;
    let t: Vec<f64> = (1..=h_ours.len()).map(|k| k as f64 * DT_S).collect();
    let mut fig = Figure::new("t (s)").title("Seed 001 example (A-4D), seed 1: parameter estimates ±σ");
    for j in 0..9 {
        let col = |h: &[Run], f: fn(&Run, usize) -> f64| h.iter().map(|r| f(r, j)).collect::<Vec<f64>>();
        let (po, so) = (col(&h_ours, |r, j| r.p[j]), col(&h_ours, |r, j| r.sigma[j]));
        let pp = col(&h_paper, |r, j| r.p[j]);
        let truth = vec![Longitudinal::<f64>::TABLE1_TRUE[j]; t.len()];
        fig = fig.panel(
            Panel::new(Longitudinal::<f64>::NAMES[j], Longitudinal::<f64>::NAMES[j])
                .band(Band::around("ours ±σ", &t, &po, &so, 1.0, Colour::BLUE))
                .line(Line::new("ours", &t, &po, Colour::BLUE))
                .line(Line::new("paper's method", &t, &pp, Colour::ORANGE))
                .line(Line::new("truth", &t, &truth, Colour::BLACK).dashed()),
        );
    }
    std::fs::create_dir_all(out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;
    let path = out_dir.join("table1_parameters.svg");
    fig.write_svg(&path).map_err(|e| format!("{e:?}"))?;
    Ok((out, vec![path]))
}

/// [`identify_with_gust_states`] with the z accelerometer as a sixth output ([`LongitudinalGustAz`]).
pub fn identify_with_accelerometer(flight: &Flight, q_small: f64, sensitivity: Sensitivity) -> Option<Run> {
    let noise = |i: usize| if i < 5 { NOISE[i] } else { AZ_NOISE_MPS2 };
    let r_x = SMatrix::<f64, 6, 6>::from_diagonal(&SVector::from_fn(|i, _| noise(i) * noise(i)));
    let (model, q_x, x0, p_x0) = gust_filter(flight, q_small);
    let measured = |k: usize| SVector::<f64, 6>::from_fn(|i, _| if i < 5 { flight.y[k][i] } else { flight.az[k] });
    run_filter(
        LongitudinalGustAz(model),
        q_x,
        r_x,
        x0,
        p_x0,
        sensitivity,
        flight,
        measured,
        None,
    )
}

/// Seed 000's equation-error PCA-GTLS on the same flight, for issue 5 §2's comparison: the lift and
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
    let sl = lift.covariance().map(|c| c.diagonal().map(f64::sqrt));
    let sm = pitch.covariance().map(|c| c.diagonal().map(f64::sqrt));
    let sl = |i: usize| sl.as_ref().map(|s| s[i]).unwrap_or(f64::NAN);
    let sm = |i: usize| sm.as_ref().map(|s| s[i]).unwrap_or(f64::NAN);
    Run {
        p: [tl[0], tl[2], tl[3], tl[1], tm[0], tm[2], tm[3], tm[4], tm[1]],
        sigma: [sl(0), sl(2), sl(3), sl(1), sm(0), sm(2), sm(3), sm(4), sm(1)],
    }
}
