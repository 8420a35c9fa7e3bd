//! Long runs: hours of simulated flight streamed through the on-board `f32` path,
//! watching for anything that drifts, saturates or loses its numerical health.
//!
//! ## The flight ([`LongRunConfig`])
//! The main job's airframe and sensors (`skywalker_2013_mod`, every hidden effect, light Dryden
//! turbulence, the default sensors with per-run biases), at 100 Hz. The time line, for a duration
//! `D` (10 h for the benchmark, 10 min for the CI slice):
//! * **mixed excitation** in cycles of `max(100 s, D/40)` (900 s at 10 h): the first half of each
//!   cycle repeats the main job's 8 s block (elevator 3-2-1-1 and doublet, aileron 3-2-1-1, rudder
//!   doublet), the second half is cruise without manoeuvres;
//! * **calm cruise** from `D/10` to `D/5` (an hour at 10 h): no manoeuvres at all;
//! * **two parameter jumps**, at `D/3` and `2D/3` rounded down to the start of a cycle (so an
//!   excitation phase follows each): first the seed's Fig. 2 change of `C_m`
//!   (`ΔC_m0 = +0.005, ΔC_mα = +0.4, ΔC_mq = +4`), then a loss of roll damping and aileron power
//!   (`ΔC_lp = +0.2, ΔC_lδa = −0.05`).
//!
//! The sensor log is streamed ([`crate::sim::Simulator`]), converted to `f32` and fed to
//! [`aerosid_core::aero::onboard::pipeline`], exactly as `crate::experiment` and the firmware do;
//! nothing per sample is kept, so memory stays flat.
//!
//! ## What is measured ([`LongRunReport`])
//! Per coefficient over every sample: the worst `‖VᵀV − I‖_F`, the smallest and largest `λ_F`, `k`,
//! `N_eff`, `σ_1`, the largest `|θ|`, re-orthonormalisations, refusals by the estimator, and whether
//! anything was ever non-finite. For each jump, per changed parameter: the error just before it
//! (against the old truth), the time after it until the estimate came within a quarter of the jump
//! of the new truth and stayed there to the end of that excitation phase, and the error at the end
//! of that phase. Drift: during the calm hour, the largest change of any estimated parameter of the
//! coefficients that stay fully excited, relative to that parameter's typical magnitude
//! ([`aerosid_core::aero::model::typical`], the weights of eq. 23).

use crate::experiment::{regressor_lists, trim_input, truth_parameters};
use crate::flights::m;
use crate::sim::{
    self, Channel, CoeffModel, LinearAero, ParameterJump, Schedule, Shape, SimConfig, Simulator, Turbulence,
};
use aerosid_core::aero::model::idx;
use aerosid_core::aero::pipeline::CoefficientStatus;
use aerosid_core::aero::{onboard, AeroModels, Pipeline, Regressor, SensorSample};
use aerosid_core::estimator::Estimator;
use aerosid_core::gtls::Gtls;
use aerosid_core::Error;
use std::fmt::Write;

/// Sample rate, Hz.
pub const RATE_HZ: f64 = 100.0;

/// The long run's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct LongRunConfig {
    /// Flight duration, s.
    pub duration_s: f64,
    /// Seed of turbulence and sensors.
    pub seed: u64,
}

impl LongRunConfig {
    /// `hours` of flight with `seed`.
    pub fn hours(hours: f64, seed: u64) -> Self {
        Self {
            duration_s: hours * 3600.0,
            seed,
        }
    }

    /// Length of one excitation/cruise cycle, s.
    pub fn cycle_s(&self) -> f64 {
        (self.duration_s / 40.0).max(100.0)
    }

    /// The calm cruise `[start, end)`, s.
    pub fn calm_s(&self) -> (f64, f64) {
        (self.duration_s / 10.0, self.duration_s / 5.0)
    }

    /// The two jump times, s (at cycle starts).
    pub fn jumps_s(&self) -> [f64; 2] {
        let c = self.cycle_s();
        [
            (self.duration_s / 3.0 / c).floor() * c,
            (2.0 * self.duration_s / 3.0 / c).floor() * c,
        ]
    }

    /// Whether the aircraft is manoeuvring at `t_s`.
    pub fn excited_at(&self, t_s: f64) -> bool {
        let (c0, c1) = self.calm_s();
        let c = self.cycle_s();
        !(t_s >= c0 && t_s < c1) && (t_s % c) < c / 2.0 && t_s >= 20.0
    }

    /// End of the excitation phase that starts at `t_s` (a cycle start), s.
    pub fn phase_end_s(&self, t_s: f64) -> f64 {
        t_s + self.cycle_s() / 2.0
    }
}

/// The two parameter changes (module doc).
pub fn jump_deltas() -> [LinearAero; 2] {
    [
        crate::flights::pitch_jump(),
        LinearAero {
            roll: CoeffModel {
                p_n: 0.2,
                aileron: -0.05,
                ..CoeffModel::default()
            },
            ..LinearAero::default()
        },
    ]
}

/// Per coefficient, over the whole run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoefficientExtremes {
    /// Worst `‖VᵀV − I‖_F`.
    pub worst_orthonormality: f64,
    /// Smallest and largest `λ_F`.
    pub lambda: (f64, f64),
    /// Smallest `k` after the first 60 s, and the largest `k`.
    pub k: (u8, u8),
    /// Largest `N_eff`.
    pub max_n_eff: f64,
    /// Largest `σ_1`.
    pub max_sigma1: f64,
    /// Largest `|θ_i|` after the first 60 s (the first seconds of an estimator are its transient).
    pub max_abs_theta: f64,
    /// When it was reached: time, s, the parameter's index, `k` at that sample, and the `σ` the
    /// telemetry reported for that parameter then (NaN where it reports none).
    pub max_abs_theta_at: (f64, usize, u8, f64),
    /// Accepted updates.
    pub updates: u32,
    /// Re-orthonormalisations of `V`.
    pub reorthonormalisations: u32,
    /// Samples the estimator itself refused.
    pub refused_estimator: u32,
    /// Samples refused for channels or warm-up.
    pub refused_other: u32,
    /// Samples after which any observable float was NaN or infinite.
    pub non_finite: u32,
    /// Samples at which `λ_F` was at its floor.
    pub at_floor: u64,
}

impl Default for CoefficientExtremes {
    fn default() -> Self {
        Self {
            worst_orthonormality: 0.0,
            lambda: (f64::INFINITY, f64::NEG_INFINITY),
            k: (u8::MAX, 0),
            max_n_eff: 0.0,
            max_sigma1: 0.0,
            max_abs_theta: 0.0,
            max_abs_theta_at: (0.0, 0, 0, f64::NAN),
            updates: 0,
            reorthonormalisations: 0,
            refused_estimator: 0,
            refused_other: 0,
            non_finite: 0,
            at_floor: 0,
        }
    }
}

/// How one parameter followed one jump.
#[derive(Debug, Clone, PartialEq)]
pub struct JumpTracking {
    /// Which jump (0, 1).
    pub jump: usize,
    /// Coefficient ([`idx`]).
    pub coefficient: usize,
    /// Parameter index in the model.
    pub parameter: usize,
    /// The regressor it multiplies.
    pub regressor: Regressor,
    /// Truth before and after.
    pub truth: (f64, f64),
    /// Estimate just before the jump.
    pub before: f64,
    /// Time from the jump until within a quarter of the jump of the new truth for good (to the end
    /// of the phase), s; `None` if never.
    pub settle_s: Option<f64>,
    /// Estimate at the end of the excitation phase after the jump.
    pub after: f64,
}

/// What a long run found.
#[derive(Debug, Clone, PartialEq)]
pub struct LongRunReport {
    /// The settings.
    pub config: LongRunConfig,
    /// Samples processed.
    pub samples: u64,
    /// Per coefficient, indexed by [`idx`].
    pub coefficients: [CoefficientExtremes; idx::COUNT],
    /// Per changed parameter and jump.
    pub tracking: Vec<JumpTracking>,
    /// Largest change over the calm cruise of a parameter of a fully excited coefficient, relative
    /// to its typical magnitude; with the coefficient and parameter.
    pub calm_drift: (f64, usize, usize),
    /// The pipeline's health counters at the end.
    pub health: aerosid_core::aero::Health,
    /// Final estimates and truth, per coefficient.
    pub final_theta: [(Vec<f64>, Vec<f64>); idx::COUNT],
}

/// The invariants a long run must keep ([`LongRunReport::violations`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Invariants {
    /// Bound on every estimator's `‖VᵀV − I‖_F` at every sample (1e-5).
    pub orthonormality: f64,
    /// Largest settling time after a jump, s.
    pub settle_s: f64,
    /// Largest parameter change over the calm cruise, in typical magnitudes.
    pub calm_drift: f64,
    /// Range `λ_F` must stay in.
    pub lambda: (f64, f64),
}

impl Invariants {
    /// The bounds the CI slice asserts (`tests/reliability_long_run.rs`, where each is justified):
    /// orthonormality 1e-5, settling within 30 s, calm drift ≤ 0.8 typical magnitudes, `λ_F` in
    /// `[0.8, 1]` (the on-board VFF's floor).
    pub const REQUIRED: Self = Self {
        orthonormality: 1e-5,
        settle_s: 30.0,
        calm_drift: 0.8,
        lambda: (0.8 - 1e-6, 1.0),
    };
}

impl LongRunReport {
    /// Every invariant the run broke, as a sentence each (empty: none): orthonormality, non-finite
    /// state, refusals by an estimator, `λ_F` out of range, a jump not tracked (not settled within
    /// `settle_s`, or outside a quarter of the jump at the end of its phase), drift in the calm
    /// cruise, samples not all processed.
    // Negated comparisons on purpose: a NaN figure counts as broken.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn violations(&self, inv: &Invariants) -> Vec<String> {
        let mut v = Vec::new();
        let names = ["C_L", "C_D", "C_Y", "C_l", "C_m", "C_n"];
        if u64::from(self.health.samples) != self.samples {
            v.push(format!(
                "{} of {} samples reached the pipeline",
                self.health.samples, self.samples
            ));
        }
        for (i, e) in self.coefficients.iter().enumerate() {
            let n = names.get(i).copied().unwrap_or("?");
            if !(e.worst_orthonormality < inv.orthonormality) {
                v.push(format!(
                    "{n}: ‖VᵀV − I‖_F reached {:.2e} (bound {:.0e})",
                    e.worst_orthonormality, inv.orthonormality
                ));
            }
            if e.non_finite != 0 {
                v.push(format!("{n}: {} samples with non-finite state", e.non_finite));
            }
            if e.refused_estimator != 0 {
                v.push(format!("{n}: {} samples refused by the estimator", e.refused_estimator));
            }
            if !(e.lambda.0 >= inv.lambda.0 && e.lambda.1 <= inv.lambda.1) {
                v.push(format!("{n}: λ_F {:?} outside {:?}", e.lambda, inv.lambda));
            }
        }
        for t in &self.tracking {
            let band = 0.25 * (t.truth.1 - t.truth.0).abs();
            match t.settle_s {
                Some(s) if s <= inv.settle_s => {}
                s => v.push(format!(
                    "jump {}: {:?} settled after {s:?} s (bound {} s)",
                    t.jump + 1,
                    t.regressor,
                    inv.settle_s
                )),
            }
            if !((t.after - t.truth.1).abs() <= band) {
                v.push(format!(
                    "jump {}: {:?} ended at {} (truth {}, band ±{band})",
                    t.jump + 1,
                    t.regressor,
                    t.after,
                    t.truth.1
                ));
            }
        }
        if !(self.calm_drift.0 <= inv.calm_drift) {
            let (d, i, p) = self.calm_drift;
            v.push(format!(
                "calm cruise: coefficient {i} parameter {p} moved {d:.3} typical magnitudes (bound {})",
                inv.calm_drift
            ));
        }
        v
    }
}

/// Why a long run could not run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LongRunError {
    /// The simulation failed.
    Sim(sim::SimError),
    /// The pipeline could not be built.
    Pipeline(Error),
}

impl core::fmt::Display for LongRunError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Sim(e) => write!(f, "{e}"),
            Self::Pipeline(e) => write!(f, "pipeline: {e}"),
        }
    }
}

impl std::error::Error for LongRunError {}

/// The manoeuvres of the 8 s block starting at `t` (the main job's block).
fn block(t: f64) -> Schedule {
    Schedule::default()
        .with(m(Channel::Elevator, Shape::Multistep3211, t, 0.2, 0.4))
        .with(m(Channel::Elevator, Shape::Doublet, t + 2.6, 0.3, 4.0))
        .with(m(Channel::Aileron, Shape::Multistep3211, t + 0.5, 0.15, 0.3))
        .with(m(Channel::Rudder, Shape::Doublet, t + 4.5, 0.2, 2.0))
}

/// Observables of one estimator after a sample.
struct View {
    theta: Vec<f64>,
    orth: f64,
    lambda: f64,
    k: u8,
    n_eff: f64,
    sigma1: f64,
    reorth: u32,
    finite: bool,
}

fn view<const N: usize>(g: &Gtls<f32, N, 1, N>) -> View {
    let theta: Vec<f64> = g.theta().iter().map(|v| f64::from(*v)).collect();
    let s = g.singular_values();
    let finite = theta.iter().all(|v| v.is_finite())
        && s.iter().all(|v| v.is_finite())
        && g.right_singular_vectors().iter().all(|v| v.is_finite())
        && g.lambda().is_finite()
        && g.effective_samples().is_finite();
    View {
        theta,
        orth: f64::from(g.orthonormality_error()),
        lambda: f64::from(g.lambda()),
        k: g.excited() as u8,
        n_eff: f64::from(g.effective_samples()),
        sigma1: f64::from(s[0]),
        reorth: g.health().reorthonormalisations,
        finite,
    }
}

fn views(p: &Pipeline<f32>) -> [View; idx::COUNT] {
    [
        view(p.lift()),
        view(p.drag()),
        view(p.side()),
        view(p.roll()),
        view(p.pitch()),
        view(p.yaw()),
    ]
}

/// Runs the long flight (module doc), calling `progress(t_s)` every simulated minute.
pub fn run(cfg: &LongRunConfig, mut progress: impl FnMut(f64)) -> Result<LongRunReport, LongRunError> {
    let mut flight = Flight::new(cfg)?;
    let mut pipeline = onboard::pipeline::<f32>().map_err(LongRunError::Pipeline)?;
    let floor = match pipeline.settings().gtls.forgetting {
        aerosid_core::Forgetting::Variable(v) => f64::from(v.lambda_min),
        aerosid_core::Forgetting::Constant(l) => f64::from(l),
    };
    let models = AeroModels::<f32>::with_sigma_eps(onboard::SIGMA_EPS.map(|s| s as f32));
    let regs = regressor_lists(&models);
    let truth = flight.truth_by_phase(&regs);
    let mut jumps = JumpWatch::new(cfg, &truth, &regs);
    let mut calm = CalmWatch::new(cfg);
    let mut ext = [CoefficientExtremes::default(); idx::COUNT];
    let n = (cfg.duration_s * RATE_HZ).round() as u64;
    for k in 0..n {
        let t = flight.sim.time_s();
        let sample = flight.step(cfg, t);
        let step = pipeline.process(&sample.cast::<f32>());
        let v = views(&pipeline);
        for (i, e) in ext.iter_mut().enumerate() {
            // What the telemetry says of parameter p (asked only at a new maximum of |θ|).
            let sigma = |p: usize| f64::from(aerosid_core::mavlink::telemetry::reports(&pipeline)[i].sigma[p]);
            e.record(&step.status[i], &v[i], t, floor, sigma);
        }
        jumps.record(&v, t);
        calm.record(&v, &regs, t);
        if k % 6000 == 0 {
            progress(t);
        }
    }
    let v = views(&pipeline);
    Ok(LongRunReport {
        config: cfg.clone(),
        samples: n,
        coefficients: ext,
        tracking: jumps.tracking,
        calm_drift: calm.drift,
        health: *pipeline.health(),
        final_theta: core::array::from_fn(|i| (v[i].theta.clone(), truth[2][i].clone())),
    })
}

/// Length of a manoeuvre block, s.
const BLOCK_S: f64 = 8.0;

/// The simulated flight (module doc): the simulator, the 8 s manoeuvre blocks and the two jumps.
struct Flight {
    sim: Simulator,
    /// The settings it started from (the first jump planted).
    start: SimConfig,
    deltas: [LinearAero; 2],
    jumps_s: [f64; 2],
    /// When the next block may begin, s.
    next_block_s: f64,
    second_jump_armed: bool,
}

impl Flight {
    fn new(cfg: &LongRunConfig) -> Result<Self, LongRunError> {
        let mut start = SimConfig {
            turbulence: Some(Turbulence::mil_f_8785c_low_altitude(100.0, Turbulence::W20_LIGHT_MPS)),
            duration_s: cfg.duration_s,
            seed: cfg.seed,
            ..SimConfig::default()
        };
        let deltas = jump_deltas();
        let jumps_s = cfg.jumps_s();
        start.plant.jump = Some(ParameterJump {
            at_s: jumps_s[0],
            delta: deltas[0],
        });
        let sim = Simulator::new(start.clone()).map_err(LongRunError::Sim)?;
        Ok(Self {
            sim,
            start,
            deltas,
            jumps_s,
            next_block_s: 20.0,
            second_jump_armed: false,
        })
    }

    /// Truth before, between and after the jumps, per coefficient in the parameter order of
    /// `regs`, linearised at the trim.
    fn truth_by_phase(&self, regs: &[Vec<Regressor>; idx::COUNT]) -> [[Vec<f64>; idx::COUNT]; 3] {
        let x0 = trim_input(&crate::sim::SimOutput {
            trim: *self.sim.trim(),
            samples: Vec::new(),
            truth: Vec::new(),
            biases: self.sim.biases(),
        });
        let plant0 = &self.start.plant;
        let [d1, d2] = &self.deltas;
        let lin = [
            plant0.truth.linearise(&x0),
            plant0.truth_at(self.jumps_s[0]).linearise(&x0),
            crate::sim::TruthAero {
                linear: plant0.truth.linear.plus(d1).plus(d2),
                ..plant0.truth
            }
            .linearise(&x0),
        ];
        core::array::from_fn(|j| {
            let a = lin[j].to_array();
            core::array::from_fn(|i| truth_parameters(&a[i], &regs[i]))
        })
    }

    /// The sensor sample after one step from time `t`: a manoeuvre block begins when one is due
    /// (inside an excitation phase), and once the first jump is passed the second is armed.
    fn step(&mut self, cfg: &LongRunConfig, t: f64) -> SensorSample<f64> {
        // Manoeuvres: one 8 s block at a time, inside excitation phases.
        if t >= self.next_block_s - 1e-9 {
            let sched = if cfg.excited_at(t) && cfg.excited_at(t + BLOCK_S - 0.01) {
                block(t)
            } else {
                Schedule::default()
            };
            self.sim.config_mut().schedule = sched;
            self.next_block_s += BLOCK_S;
        }
        // The second jump: the first becomes part of the truth, the second is armed.
        if !self.second_jump_armed && t >= self.jumps_s[0] {
            let plant = &mut self.sim.config_mut().plant;
            plant.truth.linear = plant.truth.linear.plus(&self.deltas[0]);
            plant.jump = Some(ParameterJump {
                at_s: self.jumps_s[1],
                delta: self.deltas[1],
            });
            self.second_jump_armed = true;
        }
        self.sim.step().0
    }
}

impl CoefficientExtremes {
    /// One sample of the estimator: its `status` and observables `w` at time `t`; `floor` the
    /// VFF's `λ` floor, `sigma(p)` the σ the telemetry reports for parameter `p`.
    fn record(&mut self, status: &CoefficientStatus<f32>, w: &View, t: f64, floor: f64, sigma: impl Fn(usize) -> f64) {
        match status {
            Ok(_) => self.updates += 1,
            Err(aerosid_core::aero::Refusal::Estimator(_)) => self.refused_estimator += 1,
            Err(_) => self.refused_other += 1,
        }
        if !w.finite {
            self.non_finite += 1;
        }
        self.worst_orthonormality = self.worst_orthonormality.max(w.orth);
        self.lambda = (self.lambda.0.min(w.lambda), self.lambda.1.max(w.lambda));
        if t >= 60.0 {
            self.k.0 = self.k.0.min(w.k);
        }
        self.k.1 = self.k.1.max(w.k);
        self.max_n_eff = self.max_n_eff.max(w.n_eff);
        self.max_sigma1 = self.max_sigma1.max(w.sigma1);
        if t >= 60.0 {
            for (p, x) in w.theta.iter().enumerate() {
                if x.abs() > self.max_abs_theta {
                    // What the telemetry would have said of it (rare: only at a new maximum).
                    self.max_abs_theta = x.abs();
                    self.max_abs_theta_at = (t, p, w.k, sigma(p));
                }
            }
        }
        self.reorthonormalisations = w.reorth;
        if w.lambda <= floor {
            self.at_floor += 1;
        }
    }
}

/// How the changed parameters follow each jump ([`JumpTracking`]).
struct JumpWatch {
    tracking: Vec<JumpTracking>,
    /// Per tracked parameter: time it last entered the band (None while outside).
    entered: Vec<Option<f64>>,
    jump_times: [f64; 2],
    phase_ends: [f64; 2],
}

impl JumpWatch {
    /// The parameters each jump changes (`truth` per phase, [`Flight::truth_by_phase`]).
    fn new(cfg: &LongRunConfig, truth: &[[Vec<f64>; idx::COUNT]; 3], regs: &[Vec<Regressor>; idx::COUNT]) -> Self {
        let mut tracking = Vec::new();
        for jump in 0..2 {
            for i in 0..idx::COUNT {
                for p in 0..regs[i].len() {
                    let (a, b) = (truth[jump][i][p], truth[jump + 1][i][p]);
                    if (a - b).abs() > 1e-9 {
                        tracking.push(JumpTracking {
                            jump,
                            coefficient: i,
                            parameter: p,
                            regressor: regs[i][p],
                            truth: (a, b),
                            before: f64::NAN,
                            settle_s: None,
                            after: f64::NAN,
                        });
                    }
                }
            }
        }
        let [t1, t2] = cfg.jumps_s();
        Self {
            entered: vec![None; tracking.len()],
            tracking,
            jump_times: [t1, t2],
            phase_ends: [cfg.phase_end_s(t1), cfg.phase_end_s(t2)],
        }
    }

    /// The estimates `v` at time `t`: the last one before its jump, and after it until the end of
    /// the phase whether it is within a quarter of the jump of the new truth, and since when.
    fn record(&mut self, v: &[View; idx::COUNT], t: f64) {
        for (j, tr) in self.tracking.iter_mut().enumerate() {
            let th = v[tr.coefficient].theta[tr.parameter];
            let (tj, tend) = (self.jump_times[tr.jump], self.phase_ends[tr.jump]);
            if t < tj {
                tr.before = th;
                continue;
            }
            if t > tend {
                continue;
            }
            let band = 0.25 * (tr.truth.1 - tr.truth.0).abs();
            if (th - tr.truth.1).abs() <= band {
                self.entered[j].get_or_insert(t);
            } else {
                self.entered[j] = None;
            }
            tr.after = th;
            tr.settle_s = self.entered[j].map(|e| e - tj);
        }
    }
}

/// The largest change over the calm cruise of a parameter of a fully excited coefficient.
struct CalmWatch {
    /// The calm cruise `[start, end)`, s.
    window_s: (f64, f64),
    /// The estimates at its start.
    start: Option<[Vec<f64>; idx::COUNT]>,
    /// The largest change in typical magnitudes, with the coefficient and parameter.
    drift: (f64, usize, usize),
}

impl CalmWatch {
    fn new(cfg: &LongRunConfig) -> Self {
        Self {
            window_s: cfg.calm_s(),
            start: None,
            drift: (0.0, 0, 0),
        }
    }

    /// The estimates `v` at time `t`, against those at the start of the calm cruise.
    fn record(&mut self, v: &[View; idx::COUNT], regs: &[Vec<Regressor>; idx::COUNT], t: f64) {
        let (calm0, calm1) = self.window_s;
        if !(t >= calm0 && t < calm1) {
            return;
        }
        let start = self
            .start
            .get_or_insert_with(|| core::array::from_fn(|i| v[i].theta.clone()));
        for i in 0..idx::COUNT {
            if usize::from(v[i].k) + 1 < regs[i].len() {
                continue;
            }
            for p in 0..regs[i].len() {
                let d = (v[i].theta[p] - start[i][p]).abs() / typical_magnitude(i, p);
                if d > self.drift.0 {
                    self.drift = (d, i, p);
                }
            }
        }
    }
}

/// The typical magnitude of parameter `p` of coefficient `i` (the weights of eq. 23; 1 past
/// the table).
fn typical_magnitude(i: usize, p: usize) -> f64 {
    use aerosid_core::aero::model::typical::*;
    let row: &[f64] = match i {
        idx::LIFT => &LIFT,
        idx::DRAG => &DRAG,
        idx::SIDE => &SIDE,
        idx::ROLL => &ROLL,
        idx::PITCH => &PITCH,
        _ => &YAW,
    };
    row.get(p).copied().unwrap_or(1.0)
}

/// The report as the `aerosid long-run` table.
pub fn format_report(r: &LongRunReport, wall_s: f64) -> String {
    let mut s = String::new();
    write_settings(&mut s, r, wall_s);
    write_extremes(&mut s, &r.coefficients);
    write_tracking(&mut s, &r.tracking);
    let names = crate::experiment::COEFFICIENT_NAMES;
    let (d, i, p) = r.calm_drift;
    let _ = writeln!(
        s,
        "\ncalm cruise drift (fully excited coefficients): largest parameter change {:.3} of its typical magnitude ({} parameter {})",
        d, names[i], p
    );
    let h = &r.health;
    let _ = writeln!(
        s,
        "pipeline health: {} samples; per coefficient updates {:?}",
        h.samples,
        h.coefficients.map(|c| c.updates)
    );
    s
}

/// The run's settings and time line.
fn write_settings(s: &mut String, r: &LongRunReport, wall_s: f64) {
    let c = &r.config;
    let [t1, t2] = c.jumps_s();
    let (c0, c1) = c.calm_s();
    let _ = writeln!(
        s,
        "long run: {:.2} h simulated ({} samples at 100 Hz), seed {}, f32 on-board pipeline (VFF); {:.0} s wall",
        c.duration_s / 3600.0,
        r.samples,
        c.seed,
        wall_s
    );
    let _ = writeln!(
        s,
        "time line: excitation/cruise cycles of {:.0} s, calm cruise {:.0}–{:.0} s, jumps at {:.0} s (C_m) and {:.0} s (C_l)",
        c.cycle_s(),
        c0,
        c1,
        t1,
        t2
    );
}

/// The table of each coefficient's extremes, the worst orthonormality error and where each
/// largest `|θ|` was reached.
fn write_extremes(s: &mut String, coefficients: &[CoefficientExtremes; idx::COUNT]) {
    let names = crate::experiment::COEFFICIENT_NAMES;
    let _ = writeln!(
        s,
        "\ncoef  worst ‖VᵀV−I‖_F   λ_F min–max      k min–max  N_eff max   σ1 max     |θ| max  reorth  refused (est/other)  non-finite  at floor"
    );
    for (i, e) in coefficients.iter().enumerate() {
        let _ = writeln!(
            s,
            "{:<5} {:>14.2e}   {:.4}–{:.4}   {}–{}        {:>9.0}  {:>9.1}  {:>8.3}  {:>6}  {:>6} / {:<10}  {:>10}  {:>8}",
            names[i],
            e.worst_orthonormality,
            e.lambda.0,
            e.lambda.1,
            e.k.0,
            e.k.1,
            e.max_n_eff,
            e.max_sigma1,
            e.max_abs_theta,
            e.reorthonormalisations,
            e.refused_estimator,
            e.refused_other,
            e.non_finite,
            e.at_floor
        );
    }
    let worst = coefficients.iter().map(|e| e.worst_orthonormality).fold(0.0, f64::max);
    let _ = writeln!(
        s,
        "worst orthonormality error of any estimator: {worst:.2e} (bound 1e-5)"
    );
    for (i, e) in coefficients.iter().enumerate() {
        let (t, p, k, sigma) = e.max_abs_theta_at;
        let _ = writeln!(
            s,
            "largest |θ| of {} after the first minute: {:.3} (parameter {p}) at {t:.2} s, k = {k}, reported σ {sigma:.3}",
            names[i], e.max_abs_theta
        );
    }
}

/// The table of how each changed parameter followed its jump.
fn write_tracking(s: &mut String, tracking: &[JumpTracking]) {
    let names = crate::experiment::COEFFICIENT_NAMES;
    let _ = writeln!(s, "\njump  param        truth before → after    estimate before   settled within ¼ of the jump   estimate at phase end");
    for t in tracking {
        let _ = writeln!(
            s,
            "{}     {:<12} {:>+9.4} → {:>+9.4}    {:>+9.4}         {:>24}         {:>+9.4}",
            t.jump + 1,
            format!("{}:{:?}", names[t.coefficient], t.regressor),
            t.truth.0,
            t.truth.1,
            t.before,
            t.settle_s.map_or("never".to_string(), |x| format!("after {x:.1} s")),
            t.after
        );
    }
}
