//! Simulated flights through the on-board identification, as the firmware would run it (seed
//! 000 Section VI-A, Fig. 1–2).
//!
//! [`run`] simulates a flight ([`sim::simulate`]), converts every `f64` [`SensorSample`](aerosid_core::aero::SensorSample) to `f32`
//! and feeds it to the on-board [`Pipeline<f32>`] (synthesis, six PCA-GTLS estimators). Alongside,
//! an RLS baseline ([`aerosid_core::Rls`], the seed's "sequential OLS") per coefficient is updated
//! with the *same* regressor vector and output the pipeline used ([`PipelineStep::regressors`](aerosid_core::aero::PipelineStep::regressors),
//! including the moment prefilter) exactly when the pipeline's estimator accepted the sample.
//!
//! Recorded per sample and coefficient ([`CoefficientTrace`]): GTLS `θ`, `k` (eq. 21), the `λ_F`
//! for the next sample, the singular values (eq. 13) and the excitation threshold (eq. 21); RLS `θ`.
//! The truth is [`TruthAero::linearise`](crate::sim::TruthAero::linearise) at the trim condition,
//! before and (with a [`ParameterJump`](crate::sim::ParameterJump)) after the jump, mapped to each
//! model's parameter order ([`truth_parameters`]).
//!
//! `σ_ε` (eq. 41, the last diagonal entry of `W_T`) is a setting; [`mc_sigma_eps`] computes it with
//! the host Monte Carlo ([`crate::mc::synth`] defaults).

use crate::mc::{synth, McError, McSettings};
use crate::sim::{self, AeroInput, CoeffModel, LinearAero, SimConfig, SimError, SimOutput};
use aerosid_core::aero::model::idx;
use aerosid_core::aero::pipeline::MAX_PARAMETERS;
use aerosid_core::aero::{AeroModels, Pipeline, PipelineSettings, Regressor};
use aerosid_core::estimator::Estimator;
use aerosid_core::gtls::Gtls;
use aerosid_core::rls::{Rls, RlsSettings};
use aerosid_core::Error;
use nalgebra::SVector;

/// Names of the coefficients, indexed by [`idx`].
pub const COEFFICIENT_NAMES: [&str; idx::COUNT] = ["C_L", "C_D", "C_Y", "C_l", "C_m", "C_n"];

/// What to fly and how to identify it.
#[derive(Debug, Clone, PartialEq)]
pub struct ExperimentConfig {
    /// The simulated flight.
    pub sim: SimConfig,
    /// The on-board pipeline's settings (`f32`, as on the chip).
    pub pipeline: PipelineSettings<f32>,
    /// `σ_ε` per coefficient, indexed by [`idx`] (eq. 41; see [`mc_sigma_eps`]).
    pub sigma_eps: [f64; idx::COUNT],
    /// The RLS baseline's settings (`f32`).
    pub rls: RlsSettings<f32>,
}

impl ExperimentConfig {
    /// Defaults: the given flight, default pipeline (constant `λ_F = 1`), default RLS (`λ = 1`),
    /// and `σ_ε` given by the caller.
    pub fn new(sim: SimConfig, sigma_eps: [f64; idx::COUNT]) -> Self {
        Self {
            sim,
            pipeline: PipelineSettings::default(),
            sigma_eps,
            rls: RlsSettings::default(),
        }
    }
}

/// The time histories of one coefficient's estimators. Vectors are indexed by sample (the same
/// index as [`Experiment::t_s`]); parameter vectors are in the model's regressor order
/// ([`CoefficientTrace::regressors`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CoefficientTrace {
    /// The model's regressors (parameter order).
    pub regressors: Vec<Regressor>,
    /// Whether the pipeline's estimator accepted the sample.
    pub updated: Vec<bool>,
    /// GTLS `θ̂` after the sample.
    pub theta: Vec<Vec<f64>>,
    /// GTLS `σ` of each parameter (square roots of the eq. 17 diagonal); NaN while eq. 17 is not
    /// available (not fully excited, or too few samples).
    pub sigma: Vec<Vec<f64>>,
    /// GTLS number of excited directions `k` (eq. 21).
    pub k: Vec<u8>,
    /// GTLS `λ_F` to be applied to the next sample.
    pub lambda: Vec<f64>,
    /// GTLS singular values `σ_1 ≥ … ≥ σ_NA` (eq. 13).
    pub singular_values: Vec<Vec<f64>>,
    /// GTLS excitation threshold (eq. 21); NaN while `N_eff ≤ n_θ`.
    pub threshold: Vec<f64>,
    /// RLS `θ̂` after the sample (updated on the same samples with the same regressors).
    pub rls_theta: Vec<Vec<f64>>,
    /// The truth linearised at trim before any parameter jump, in parameter order.
    pub truth: Vec<f64>,
    /// The truth linearised at trim after the parameter jump (equal to `truth` without one).
    pub truth_after_jump: Vec<f64>,
}

impl CoefficientTrace {
    /// The number of parameters `n_θ`.
    pub fn n_theta(&self) -> usize {
        self.regressors.len()
    }
    /// The truth in force at time `t_s` given the jump time.
    pub fn truth_at(&self, t_s: f64, jump_at_s: Option<f64>) -> &[f64] {
        match jump_at_s {
            Some(j) if t_s >= j => &self.truth_after_jump,
            _ => &self.truth,
        }
    }
}

/// A simulated flight and its identification.
#[derive(Debug, Clone, PartialEq)]
pub struct Experiment {
    /// Sample times, s.
    pub t_s: Vec<f64>,
    /// Per coefficient, indexed by [`idx`].
    pub coefficients: [CoefficientTrace; idx::COUNT],
    /// The truth linearisation at trim (before any jump).
    pub truth: LinearAero,
    /// The truth linearisation at trim after the jump (equal to `truth` without one).
    pub truth_after_jump: LinearAero,
    /// The simulator's output (log and truth record).
    pub flight: SimOutput,
    /// The pipeline's health counters at the end.
    pub health: aerosid_core::aero::Health,
    /// Time of the parameter jump, if the flight had one, s.
    pub jump_s: Option<f64>,
}

impl Experiment {
    /// The index of the first sample at or after `t_s` (the length if none).
    pub fn index_at(&self, t_s: f64) -> usize {
        self.t_s.partition_point(|t| *t < t_s - 1e-9)
    }
}

/// Why an experiment could not run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ExperimentError {
    /// The simulation failed.
    Sim(SimError),
    /// The pipeline or an RLS estimator could not be built.
    Estimator(Error),
}

impl core::fmt::Display for ExperimentError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Sim(e) => write!(f, "{e}"),
            Self::Estimator(e) => write!(f, "estimator setup: {e:?}"),
        }
    }
}

impl std::error::Error for ExperimentError {}

/// The Monte Carlo sensor errors ([`synth::Sensors`] defaults) with the angular-acceleration error
/// of the on-board differentiator at sample period `dt_s`: the 5-point Savitzky–Golay slope
/// `(−2, −1, 0, 1, 2)/(10 dt)` has the white-noise gain `√10/(10 dt)` (31.6 s⁻¹ at 100 Hz, the
/// `synth` default). With an understated gain (an 8-sample slope, 15.43 s⁻¹) `σ_ε` of `C_m` came
/// out 0.0083 while the measured synthesis error in simulation is 0.0136, and GTLS over-corrected
/// `C_m` badly.
pub fn onboard_mc_sensors(dt_s: f64) -> synth::Sensors {
    let s = synth::Sensors::default();
    synth::Sensors {
        ang_accel_rad_s2: s.gyro_rad_s * 10f64.sqrt() / (10.0 * dt_s),
        ..s
    }
}

/// `σ_ε` of the six coefficients (eq. 41) from the host Monte Carlo with the [`synth`] default
/// problem (`skywalker_2013_mod`) and the given sensor errors, indexed by [`idx`], with `draws`
/// draws.
pub fn mc_sigma_eps(sensors: &synth::Sensors, draws: usize, seed: u64) -> Result<[f64; idx::COUNT], McError> {
    let settings = McSettings {
        draws,
        seed,
        progress: false,
        ..McSettings::default()
    };
    let rows = synth::coefficient_sigmas(
        &synth::Airframe::skywalker_2013_mod(),
        &synth::default_problem(sensors),
        &settings,
    )?;
    let mut out = [0.0; idx::COUNT];
    for (o, r) in out.iter_mut().zip(rows.iter()) {
        *o = r.mc.sigma_eps;
    }
    Ok(out)
}

/// The parameter of a truth coefficient model that multiplies regressor `r`.
pub fn truth_parameter(m: &CoeffModel, r: Regressor) -> f64 {
    match r {
        Regressor::One => m.c0,
        Regressor::Alpha => m.alpha,
        Regressor::Alpha2 => m.alpha2,
        Regressor::Beta => m.beta,
        Regressor::RollRateN => m.p_n,
        Regressor::PitchRateN => m.q_n,
        Regressor::YawRateN => m.r_n,
        Regressor::Elevator => m.elevator,
        Regressor::Aileron => m.aileron,
        Regressor::Rudder => m.rudder,
    }
}

/// The truth parameters of a linearisation in the order of a model's regressors.
pub fn truth_parameters(m: &CoeffModel, regressors: &[Regressor]) -> Vec<f64> {
    regressors.iter().map(|r| truth_parameter(m, *r)).collect()
}

/// The regressor lists of the six models, indexed by [`idx`].
pub fn regressor_lists(models: &AeroModels<f32>) -> [Vec<Regressor>; idx::COUNT] {
    [
        models.lift.regressors.to_vec(),
        models.drag.regressors.to_vec(),
        models.side.regressors.to_vec(),
        models.roll.regressors.to_vec(),
        models.pitch.regressors.to_vec(),
        models.yaw.regressors.to_vec(),
    ]
}

/// The regressors of eq. 3 at the trim of a flight (rates zero, level).
pub fn trim_input(out: &SimOutput) -> AeroInput {
    AeroInput {
        alpha_rad: out.trim.alpha_rad,
        elevator_rad: out.trim.controls.elevator_rad,
        aileron_rad: out.trim.controls.aileron_rad,
        rudder_rad: out.trim.controls.rudder_rad,
        ..AeroInput::default()
    }
}

/// Appends the state of one GTLS estimator and its RLS twin to a trace; updates the RLS first if
/// the pipeline accepted the sample.
#[allow(clippy::too_many_arguments)]
fn record<const N: usize>(
    tr: &mut CoefficientTrace,
    gtls: &Gtls<f32, N, 1, N>,
    rls: &mut Rls<f32, N>,
    accepted: bool,
    x: &[f32; MAX_PARAMETERS],
    z: f32,
) {
    if accepted {
        let x = SVector::<f32, N>::from_fn(|i, _| x[i]);
        // A refusal leaves the RLS state unchanged (visible as a flat RLS trace).
        let _refused = rls.update(&x, z).is_err();
    }
    tr.updated.push(accepted);
    tr.theta.push(gtls.theta().iter().map(|v| *v as f64).collect());
    tr.sigma.push(match gtls.covariance() {
        Ok(c) => (0..N).map(|i| (c[(i, i)] as f64).max(0.0).sqrt()).collect(),
        Err(_) => vec![f64::NAN; N],
    });
    tr.k.push(gtls.excited() as u8);
    tr.lambda.push(gtls.lambda() as f64);
    tr.singular_values
        .push(gtls.singular_values().iter().map(|v| *v as f64).collect());
    tr.threshold.push(gtls.threshold().map_or(f64::NAN, |v| v as f64));
    tr.rls_theta.push(rls.theta().iter().map(|v| *v as f64).collect());
}

/// Simulates the flight and runs the on-board pipeline (in `f32`) and the RLS baseline on it
/// (module doc).
pub fn run(cfg: &ExperimentConfig) -> Result<Experiment, ExperimentError> {
    let flight = sim::simulate(&cfg.sim).map_err(ExperimentError::Sim)?;
    let sigma: [f32; idx::COUNT] = cfg.sigma_eps.map(|s| s as f32);
    let models = AeroModels::<f32>::with_sigma_eps(sigma);
    let airframe = cfg.sim.plant.airframe.frame.cast::<f32>();
    let mut pipeline = Pipeline::new(airframe, models, cfg.pipeline).map_err(ExperimentError::Estimator)?;
    let e = ExperimentError::Estimator;
    let mut rls_l = Rls::<f32, 4>::new(cfg.rls).map_err(e)?;
    let mut rls_d = Rls::<f32, 5>::new(cfg.rls).map_err(e)?;
    let mut rls_y = Rls::<f32, 6>::new(cfg.rls).map_err(e)?;
    let mut rls_r = Rls::<f32, 6>::new(cfg.rls).map_err(e)?;
    let mut rls_m = Rls::<f32, 4>::new(cfg.rls).map_err(e)?;
    let mut rls_n = Rls::<f32, 6>::new(cfg.rls).map_err(e)?;

    let x0 = trim_input(&flight);
    let truth = cfg.sim.plant.truth.linearise(&x0);
    let jump_at = cfg.sim.plant.jump.map(|j| j.at_s);
    let truth_after_jump = match jump_at {
        Some(t) => cfg.sim.plant.truth_at(t).linearise(&x0),
        None => truth,
    };
    let regs = regressor_lists(&models);
    let (tb, ta) = (truth.to_array(), truth_after_jump.to_array());
    let mut traces: [CoefficientTrace; idx::COUNT] = core::array::from_fn(|i| CoefficientTrace {
        regressors: regs[i].clone(),
        truth: truth_parameters(&tb[i], &regs[i]),
        truth_after_jump: truth_parameters(&ta[i], &regs[i]),
        ..CoefficientTrace::default()
    });

    let mut t_s = Vec::with_capacity(flight.samples.len());
    for s in &flight.samples {
        let step = pipeline.process(&s.cast::<f32>());
        let z = step
            .synthesis
            .as_ref()
            .map_or([0.0; idx::COUNT], |y| y.coefficients.as_array());
        let ok = |i: usize| step.status[i].is_ok();
        let x = &step.regressors;
        let [tl, td, ty, tr, tm, tn] = &mut traces;
        let (l, d, y, r, m, n) = (idx::LIFT, idx::DRAG, idx::SIDE, idx::ROLL, idx::PITCH, idx::YAW);
        record(tl, pipeline.lift(), &mut rls_l, ok(l), &x[l], z[l]);
        record(td, pipeline.drag(), &mut rls_d, ok(d), &x[d], z[d]);
        record(ty, pipeline.side(), &mut rls_y, ok(y), &x[y], z[y]);
        record(tr, pipeline.roll(), &mut rls_r, ok(r), &x[r], z[r]);
        record(tm, pipeline.pitch(), &mut rls_m, ok(m), &x[m], z[m]);
        record(tn, pipeline.yaw(), &mut rls_n, ok(n), &x[n], z[n]);
        t_s.push(s.t_s);
    }
    Ok(Experiment {
        t_s,
        coefficients: traces,
        truth,
        truth_after_jump,
        health: *pipeline.health(),
        jump_s: jump_at,
        flight,
    })
}
