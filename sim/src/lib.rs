//! # aerosid-sim
//!
//! The 6-DoF flight simulator and the flights it generates: the truth the on-board identification
//! is tested against (seed 000 Section VI-A uses `last_letter` the same way).
//!
//! It depends on the core only (the sensor sample it writes, the propeller model it shares): the
//! `aerosid` tool (log writer, model-gap analysis, main job) and the tests depend on it, never the
//! reverse, so the simulator builds and tests without the tool's readers, plots and CLI.
//!
//! * [`dynamics`] — nonlinear 6-DoF rigid body (FRD body, NED earth, quaternion attitude, full
//!   inertia with `Jxz`), RK4 at an internal step (default 2 ms); commands held per output period.
//! * [`actuator`] — servos (first-order lag with a rate limit) between the held commands and the
//!   surfaces, so surfaces and `q̇` are continuous as in flight.
//! * [`aero`] — truth aerodynamics: eq. 3 plus switchable hidden effects, eq. 1–2, and the truth's
//!   linearisation (the reference the estimators are compared against).
//! * [`airframe`] — `skywalker_2013_mod` (default) and the Rascal 110.
//! * [`atmosphere`] — ISA density, MIL-F-8785C Dryden turbulence (exact discretisation).
//! * [`propulsion`] — the propeller `C_T(J)`, `C_P(J)` model the on-board code also uses.
//! * [`trim`] — straight-level trim; [`manoeuvre`] — doublet, 3-2-1-1, sweep, step; [`sensors`].
//! * [`test_card`] — a flight-test card of short manoeuvres; [`uav_log`] — a small UAV autopilot's
//!   log of a flight (per-channel rates, lags, sample-and-hold, α and β estimated, no vanes).
//!
//! [`simulate`] runs a flight at 100 Hz (by default) and returns the sensor log
//! ([`aerosid_core::aero::SensorSample`]) with a truth record per sample. Everything is `f64`,
//! seeded, without global state.
//!
//! ```
//! use aerosid_sim::{simulate, SimConfig};
//! // Two seconds of the default flight (the Skywalker from trim at 15 m/s, seeded),
//! // logged at 100 Hz.
//! let cfg = SimConfig { duration_s: 2.0, ..SimConfig::default() };
//! let flight = simulate(&cfg)?;
//! assert_eq!(flight.samples.len(), 200);
//! assert_eq!(flight.truth.len(), flight.samples.len());
//! # Ok::<(), aerosid_sim::SimError>(())
//! ```

pub mod actuator;
pub mod aero;
pub mod airframe;
pub mod airframe_file;
pub mod atmosphere;
pub mod dynamics;
pub mod flights;
pub mod manoeuvre;
pub mod propulsion;
pub mod sensors;
pub mod test_card;
pub mod trim;
pub mod uav_log;

pub use actuator::Servo;
pub use aero::{AeroInput, CoeffModel, Coefficients, LinearAero, ParameterJump, StallBlend, TruthAero, TruthEffects};
pub use airframe::SimAirframe;
pub use airframe_file::{parse_airframe, read_airframe, AirframeFileError};
pub use atmosphere::{Dryden, Turbulence};
pub use dynamics::{Controls, Evaluation, Plant, RigidState};
pub use manoeuvre::{Channel, Manoeuvre, Schedule, Shape};
pub use sensors::{FaultChannel, SensorFault, SensorModel, SensorNoise};
pub use trim::{trim_level, Trim, TrimError};

use aerosid_core::aero::SensorSample;
use nalgebra::Vector3;

/// A weak stabiliser around trim (perfect state feedback), added to the manoeuvre inputs so that
/// long flights stay bounded: pitch attitude with altitude hold, roll attitude, yaw damper,
/// airspeed by throttle. Signs follow the control derivatives of the airframe.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stabiliser {
    /// Elevator per pitch-attitude error, rad/rad (default 0.5).
    pub k_pitch: f64,
    /// Elevator per pitch rate, rad/(rad/s) (default 0.05).
    pub k_q: f64,
    /// Pitch reference per altitude error, rad/m (default 0.01, clamped to ±0.1 rad).
    pub k_altitude: f64,
    /// Aileron per roll error, rad/rad (default 0.3).
    pub k_roll: f64,
    /// Aileron per roll rate, rad/(rad/s) (default 0.03).
    pub k_p: f64,
    /// Rudder per yaw rate, rad/(rad/s) (default 0.05).
    pub k_r: f64,
    /// Throttle per airspeed error, 1/(m/s) (default 0.05).
    pub k_airspeed: f64,
}

impl Default for Stabiliser {
    fn default() -> Self {
        Self {
            k_pitch: 0.5,
            k_q: 0.05,
            k_altitude: 0.01,
            k_roll: 0.3,
            k_p: 0.03,
            k_r: 0.05,
            k_airspeed: 0.05,
        }
    }
}

impl Stabiliser {
    /// The stabiliser's increments to the trim controls at state `x` (airspeed `v_mps`).
    pub fn increments(
        &self,
        plant: &Plant,
        trim: &Trim,
        airspeed_ref_mps: f64,
        x: &RigidState,
        v_mps: f64,
    ) -> Controls {
        let a = &plant.airframe.aero;
        let sg = |c: f64| if c < 0.0 { -1.0 } else { 1.0 };
        let e = x.euler_rad();
        let t0 = trim.state.euler_rad();
        let theta_ref = t0.y + (self.k_altitude * (trim.state.altitude_m() - x.altitude_m())).clamp(-0.1, 0.1);
        let w = &x.rate_rad_s;
        Controls {
            elevator_rad: sg(a.pitch.elevator) * (self.k_pitch * (theta_ref - e.y) - self.k_q * w.y),
            aileron_rad: sg(a.roll.aileron) * (self.k_roll * (t0.x - e.x) - self.k_p * w.x),
            rudder_rad: -sg(a.yaw.rudder) * self.k_r * w.z,
            throttle: self.k_airspeed * (airspeed_ref_mps - v_mps),
        }
    }
}

/// A simulated flight's settings. `Default` is the skywalker at 15 m/s, 100 m, every hidden effect
/// on, no wind or turbulence, default sensors, stabiliser and servos on, 60 s at 100 Hz with 2 ms RK4
/// steps.
#[derive(Debug, Clone, PartialEq)]
pub struct SimConfig {
    /// The plant (airframe, truth aerodynamics, wind, parameter jump, switches).
    pub plant: Plant,
    /// Trim airspeed, m/s.
    pub airspeed_mps: f64,
    /// Initial altitude (and height above ground for the turbulence), m.
    pub altitude_m: f64,
    /// Initial heading, rad.
    pub heading_rad: f64,
    /// Dryden turbulence (None: calm).
    pub turbulence: Option<Turbulence>,
    /// Sensor noise settings.
    pub sensors: SensorNoise,
    /// Excitation manoeuvres.
    pub schedule: Schedule,
    /// Stabiliser (None: open loop around trim).
    pub stabiliser: Option<Stabiliser>,
    /// Surface servos (None: the surfaces jump to each held command, as an ideal zero-order hold).
    pub servo: Option<Servo>,
    /// Flight duration, s.
    pub duration_s: f64,
    /// Output (sensor) period, s.
    pub output_dt_s: f64,
    /// Largest internal RK4 step, s.
    pub step_s: f64,
    /// Seed for turbulence and sensors.
    pub seed: u64,
    /// Systematic sensor errors (scale factors, extra biases, delays); empty by default.
    pub faults: Vec<sensors::SensorFault>,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self {
            plant: Plant::new(SimAirframe::skywalker_2013_mod(), TruthEffects::all()),
            airspeed_mps: 15.0,
            altitude_m: 100.0,
            heading_rad: 0.0,
            turbulence: None,
            sensors: SensorNoise::default(),
            schedule: Schedule::default(),
            stabiliser: Some(Stabiliser::default()),
            servo: Some(Servo::default()),
            duration_s: 60.0,
            output_dt_s: 0.01,
            step_s: 0.002,
            seed: 0,
            faults: Vec::new(),
        }
    }
}

/// The truth at one output instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TruthSample {
    /// Time, s.
    pub t_s: f64,
    /// The rigid-body state.
    pub state: RigidState,
    /// The applied controls: the surface positions (the servos' output) and the throttle.
    pub controls: Controls,
    /// Gust velocity, body, m/s.
    pub gust_body_mps: Vector3<f64>,
    /// Air data, truth coefficients (`C_L … C_n`), forces and moments, accelerations.
    pub eval: Evaluation,
    /// The perfect-sensor sample (what the sensors measure before noise and bias).
    pub ideal: SensorSample<f64>,
}

/// A simulated flight.
#[derive(Debug, Clone, PartialEq)]
pub struct SimOutput {
    /// The trim the flight started from.
    pub trim: Trim,
    /// The measured samples (the log).
    pub samples: Vec<SensorSample<f64>>,
    /// The truth, one per sample.
    pub truth: Vec<TruthSample>,
    /// The sensor biases of this run.
    pub biases: sensors::SensorBiases,
}

/// Why a simulation could not run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SimError {
    /// Trim failed.
    Trim(TrimError),
    /// A time setting is not positive and finite (`output_dt_s`, `step_s`, `duration_s`).
    BadTiming,
}

impl core::fmt::Display for SimError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Trim(e) => write!(f, "{e}"),
            Self::BadTiming => write!(
                f,
                "simulation: output_dt_s, step_s and duration_s must be positive and finite"
            ),
        }
    }
}

impl std::error::Error for SimError {}

impl From<TrimError> for SimError {
    fn from(e: TrimError) -> Self {
        Self::Trim(e)
    }
}

/// The ideal sensor sample of an evaluation.
pub fn ideal_sample(t_s: f64, dt_s: f64, x: &RigidState, u: &Controls, e: &Evaluation) -> SensorSample<f64> {
    SensorSample {
        t_s,
        dt_s,
        accel_mps2: e.specific_force_mps2,
        gyro_rad_s: x.rate_rad_s,
        airspeed_mps: e.airspeed_mps,
        alpha_rad: e.alpha_rad,
        beta_rad: e.beta_rad,
        euler_rad: x.euler_rad(),
        prop_speed_rad_s: e.prop.speed_rad_s,
        elevator_rad: u.elevator_rad,
        aileron_rad: u.aileron_rad,
        rudder_rad: u.rudder_rad,
        throttle: u.throttle,
        air_density_kgpm3: e.density_kgpm3,
    }
}

/// Runs a flight: trim, then `duration_s/output_dt_s` samples (the first at t = 0).
pub fn simulate(cfg: &SimConfig) -> Result<SimOutput, SimError> {
    let mut sim = Simulator::new(cfg.clone())?;
    let n = (cfg.duration_s / cfg.output_dt_s).round() as usize;
    let mut samples = Vec::with_capacity(n);
    let mut truth = Vec::with_capacity(n);
    for _ in 0..n {
        let (s, t) = sim.step();
        samples.push(s);
        truth.push(t);
    }
    Ok(SimOutput {
        trim: sim.trim,
        samples,
        truth,
        biases: sim.sensors.biases,
    })
}

/// A flight one output period at a time, for flights too long to keep in memory (the long run of
/// `aerosid::longrun`: 3.6 million samples). [`simulate`] is this, collected; `duration_s` is not
/// used here (the caller decides when to stop).
///
/// The configuration may be changed between steps through [`Simulator::config_mut`]: the schedule
/// (manoeuvres are evaluated at the absolute time of each step) and the plant (e.g. a second
/// parameter jump after the first).
#[derive(Debug, Clone)]
pub struct Simulator {
    cfg: SimConfig,
    trim: Trim,
    dryden: Option<Dryden>,
    sensors: SensorModel,
    /// The rigid-body state at the next output instant.
    x: RigidState,
    /// Surface positions (the servos' state); equal to the command without servos.
    surfaces: Controls,
    /// Ideal samples so far (kept only when the configuration has sensor faults with delays).
    ideal_history: Vec<SensorSample<f64>>,
    /// Index of the next output sample.
    k: usize,
    n_sub: usize,
    h: f64,
}

impl Simulator {
    /// Trims the plant and sets up turbulence and sensors (as [`simulate`]).
    pub fn new(cfg: SimConfig) -> Result<Self, SimError> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        if !(ok(cfg.output_dt_s) && ok(cfg.step_s) && ok(cfg.duration_s)) {
            return Err(SimError::BadTiming);
        }
        let trim = trim_level(&cfg.plant, cfg.airspeed_mps, cfg.altitude_m, cfg.heading_rad)?;
        let dt = cfg.output_dt_s;
        let n_sub = (dt / cfg.step_s).ceil().max(1.0) as usize;
        let h = dt / n_sub as f64;
        let dryden = cfg
            .turbulence
            .map(|t| Dryden::new(&t, cfg.airspeed_mps, dt, cfg.seed ^ 0x9E37_79B9_7F4A_7C15));
        let sensors = SensorModel::new(cfg.sensors, cfg.seed);
        Ok(Self {
            x: trim.state,
            surfaces: trim.controls,
            trim,
            dryden,
            sensors,
            cfg,
            ideal_history: Vec::new(),
            k: 0,
            n_sub,
            h,
        })
    }

    /// The trim the flight started from.
    pub fn trim(&self) -> &Trim {
        &self.trim
    }

    /// The configuration in force.
    pub fn config(&self) -> &SimConfig {
        &self.cfg
    }

    /// The configuration, to change the schedule or the plant before the next step.
    pub fn config_mut(&mut self) -> &mut SimConfig {
        &mut self.cfg
    }

    /// The sensor biases of this run.
    pub fn biases(&self) -> sensors::SensorBiases {
        self.sensors.biases
    }

    /// Time of the next sample, s.
    pub fn time_s(&self) -> f64 {
        self.k as f64 * self.cfg.output_dt_s
    }

    /// The next sample and its truth; then integrates to the following output instant.
    pub fn step(&mut self) -> (SensorSample<f64>, TruthSample) {
        let cfg = &self.cfg;
        let plant = &cfg.plant;
        let trim = &self.trim;
        let (k, dt, h, x) = (self.k, cfg.output_dt_s, self.h, self.x);
        let t = k as f64 * dt;
        let gust = self.dryden.as_ref().map_or_else(Vector3::zeros, Dryden::gust_body_mps);
        let mut u = trim.controls;
        let m = cfg.schedule.input(t);
        u.elevator_rad += m.elevator_rad;
        u.aileron_rad += m.aileron_rad;
        u.rudder_rad += m.rudder_rad;
        u.throttle += m.throttle;
        let surfaces = self.surfaces;
        let applied_now = |cmd: &Controls| match &cfg.servo {
            Some(_) => Controls {
                throttle: cmd.throttle,
                ..surfaces
            },
            None => *cmd,
        };
        if let Some(st) = &cfg.stabiliser {
            let v = plant.evaluate(&x, &applied_now(&u), &gust, t).airspeed_mps;
            let s = st.increments(plant, trim, cfg.airspeed_mps, &x, v);
            u.elevator_rad += s.elevator_rad;
            u.aileron_rad += s.aileron_rad;
            u.rudder_rad += s.rudder_rad;
            u.throttle += s.throttle;
        }
        let cmd = plant.saturate(&u);
        let u = applied_now(&cmd);
        let e = plant.evaluate(&x, &u, &gust, t);
        let ideal = ideal_sample(t, dt, &x, &u, &e);
        let truth = TruthSample {
            t_s: t,
            state: x,
            controls: u,
            gust_body_mps: gust,
            eval: e,
            ideal,
        };
        let sample = if cfg.faults.is_empty() {
            self.sensors.measure(&ideal)
        } else {
            self.ideal_history.push(ideal);
            let faulty = sensors::apply_faults(&cfg.faults, &self.ideal_history, k, dt);
            self.sensors.measure(&faulty)
        };
        let mut x = x;
        for i in 0..self.n_sub {
            let t0 = i as f64 * h;
            x = match &cfg.servo {
                Some(sv) => plant.rk4_step_with(&x, |s| sv.controls(&u, &cmd, t0 + s), &gust, t + t0, h),
                None => plant.rk4_step(&x, &u, &gust, t + t0, h),
            };
        }
        if let Some(sv) = &cfg.servo {
            self.surfaces = sv.controls(&u, &cmd, dt);
        }
        if let Some(d) = self.dryden.as_mut() {
            d.step();
        }
        self.x = x;
        self.k += 1;
        (sample, truth)
    }
}
